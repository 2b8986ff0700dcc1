"""The documents' commands work in the order printed, without the docs test's help: every
calibration or stimulus set a command reads is shipped or made by an earlier command of the
same document (or said how to make), and every analysis reads sessions an earlier command
records. (tests/test_docs.py runs the commands, filling what is missing with the shipped
examples; this is what a new user reading from the top meets.)"""

from __future__ import annotations

import shlex
import subprocess
from pathlib import Path

import pytest

from tests.test_docs import DOCUMENTS, commands

ROOT = Path(__file__).parents[1]


def tracked() -> set[str]:
    listed = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files"], capture_output=True, text=True, check=False
    )
    if listed.returncode != 0:
        pytest.skip("not a git checkout")
    return set(listed.stdout.split())


def _option(words: list[str], name: str) -> str | None:
    if name in words and words.index(name) + 1 < len(words):
        return words[words.index(name) + 1]
    return None


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_what_a_command_reads_is_shipped_or_made_before(document):
    shipped = tracked()
    made: set[str] = set()
    recorded: set[str] = set()  # studies whose sessions an earlier command records
    text = document.read_text()
    problems = []
    for command in commands(document):
        if not command.startswith("glarelab "):
            continue
        words = shlex.split(command)
        for name in ("--calibration", "--stimuli"):
            path = _option(words, name)
            if path is None or path in shipped or path.rstrip("/") in made:
                continue
            explained = f"`{path}`, made as" in text or f"`{path}`, made by" in text
            if not explained:
                problems.append(f"`{command}` reads {path}, which nothing before it makes")
        if words[1] == "analyse" and "--stimuli" not in words:
            study = words[2]
            if study not in recorded and any("data/" in w for w in words[3:]):
                problems.append(f"`{command}`: no command before it records {study} sessions")
        out = _option(words, "--out")
        if out is not None:
            made.add(out.rstrip("/"))
        if words[1] == "run":
            recorded.add(words[2])
    assert not problems, "\n".join(problems)
