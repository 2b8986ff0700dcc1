"""A participant's id at the session's boundary: one R or pandas would read back as a missing
value is refused (a participant "NA" dropped out of the analysis in R, read.csv)."""

import io
import shutil
import subprocess

import pandas as pd
import pytest

from glarelab.experiments.data import MISSING_IDS, SessionError, check_session_id


@pytest.mark.parametrize("participant", sorted(MISSING_IDS))
def test_an_id_read_back_as_missing_is_refused(participant):
    with pytest.raises(SessionError, match=rf"^participant '{participant}' reads back as a"):
        check_session_id(participant, 1)


def test_the_refused_ids_are_those_r_or_pandas_read_as_missing():
    ids = [*sorted(MISSING_IDS), "Na", "NONE", "p01", "nA1"]
    text = "participant,rating\n" + "".join(f"{i},1\n" for i in ids)
    read = pd.read_csv(io.StringIO(text))["participant"].isna().tolist()
    rscript = shutil.which("Rscript")
    if rscript is not None:
        done = subprocess.run(
            [rscript, "-e", "cat(as.integer(is.na(read.csv(file('stdin'))$participant)))"],
            input=text, capture_output=True, text=True, check=True, timeout=60,
        )  # fmt: skip
        read = [a or b == "1" for a, b in zip(read, done.stdout.split(), strict=True)]
    assert {i for i, missing in zip(ids, read, strict=True) if missing} == MISSING_IDS
    for participant in ("Na", "NONE", "p01", "nA1"):
        check_session_id(participant, 1)
