"""The demo runs the whole study, and its report says what the analysis computes."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from pandas.testing import assert_frame_equal

from glarelab.analysis.report import write_report
from glarelab.protocols import load_protocol

ROOT = Path(__file__).parents[1]


def test_demo_report_matches_a_fresh_analysis_and_names_the_protocol(tmp_path):
    out = tmp_path / "demo"
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "demo", "--protocol", "yoshida2008", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "[4/4] report written" in done.stderr and "report:" in done.stdout
    report = out / "report" / "report.html"
    assert report.is_file()
    csvs = sorted((out / "data").glob("sim*_yoshida2008_s1_*.csv"))
    assert len(csvs) == 10
    protocol = load_protocol("yoshida2008")
    again = write_report(protocol, csvs, tmp_path / "again", stimuli=out / "stimuli").parent
    for table in sorted((out / "report").glob("*.csv")):
        # to the last bits: statsmodels' ANOVA solves by BLAS, whose sums may differ between a
        # process and another by an ulp (the F column did, in a full run)
        assert_frame_equal(
            pd.read_csv(table), pd.read_csv(again / table.name), check_exact=False, rtol=1e-12
        )
    methods = (out / "report" / "methods.md").read_text()
    for fact in (
        "10 simulated observers",
        "0.3° disk",
        "a cloudy sky (mean 150 cd/m²) (3.2°)",
        "maximum 433 cd/m²",
        "1 m in 60 lx",
        "L_dmax = 220 cd/m²",
        "sigma_deg = 0.34",
        "220, 1165, 2110, 3055, 4000, 7000",
        "220, 1480, 2740, 4000, 7000, 10000",
        "100, 400 cd/m²",
        "2048 × 1536 px, 10-bit",
    ):
        assert fact in methods, fact
    html = report.read_text()
    assert methods.strip() in html
    provenance = json.loads((out / "report" / "provenance.json").read_text())
    assert provenance["protocol_sha256"] == protocol.sha256
    assert provenance["protocol_sha256_in_sessions"] == [protocol.sha256]
    assert len(provenance["stimulus_set_manifest_sha256"]) == 64
    assert provenance["stimulus_set_calibration_status"] == "synthetic"
    assert (
        provenance["packages"]["glarelab"]
        and "not installed" not in provenance["packages"]["glarelab"]
    )
    assert provenance["simulated"] is True
    assert [s["participant"] for s in provenance["sessions"]] == [
        f"sim{n:02d}" for n in range(1, 11)
    ]


WHOLE_STUDY_STATE = r"""
import locale, os, random, signal, sys, warnings
from pathlib import Path

import numpy as np

# what these libraries set when they are imported is theirs, as it would be in a user's script
# that imports them (statsmodels' and scipy's warnings filters, colour-science's, threadpoolctl's
# KMP_DUPLICATE_LIB_OK); what the suite does after that must leave everything as it was
import colour, matplotlib, pandas, scipy.stats, statsmodels.api, threadpoolctl  # noqa: E401

def state():
    return {
        "warnings filters": [repr(entry) for entry in warnings.filters],
        "environment": dict(os.environ),
        "numpy print options": np.get_printoptions(),
        "numpy errors": np.geterr(),
        "numpy random state": repr(np.random.get_state()),
        "random state": repr(random.getstate()),
        "threads": sorted(
            (pool["internal_api"], pool["num_threads"])
            for pool in threadpoolctl.threadpool_info()
        ),
        "matplotlib settings": {key: repr(value) for key, value in matplotlib.rcParams.items()},
        "locale": locale.setlocale(locale.LC_ALL),
        "working folder": os.getcwd(),
        "signal handlers": [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)],
    }

before = state()
from glarelab.demo import run_demo

run_demo("spencer1995", Path(sys.argv[1]), participants=2, log=lambda line: None)
after = state()
print(sorted(key for key in before if before[key] != after[key]))
"""


def test_a_whole_study_leaves_the_interpreters_global_state_as_it_was(tmp_path):
    # a user's own backend (a notebook's, a GUI's): stands for one the suite must not switch
    env = {**os.environ, "MPLBACKEND": "template"}
    done = subprocess.run(
        [sys.executable, "-c", WHOLE_STUDY_STATE, str(tmp_path / "demo")],
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
        env=env,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_a_first_demo_that_fails_leaves_no_folder(tmp_path, monkeypatch):
    """On a full disk the first demo removed its building folder but left the new --out
    holding only its listing (.glarelab-files.json)."""
    import errno

    import glarelab.demo

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(glarelab.demo, "build_stimulus_set", full)
    with pytest.raises(OSError, match="No space left"):
        glarelab.demo.run_demo("yoshida2008", tmp_path / "demo", participants=2, seed=1)
    assert list(tmp_path.iterdir()) == []
