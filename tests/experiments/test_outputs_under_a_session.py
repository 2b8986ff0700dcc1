"""A session's output folder removed while it runs is not reported as completed, and the trials
it held are written back."""

import shutil
import subprocess
import sys
import time

PYTHON = [sys.executable, "-m", "glarelab"]


def test_an_output_folder_removed_mid_session_is_not_completed_and_loses_no_trial(tmp_path):
    out = tmp_path / "data"
    process = subprocess.Popen(
        [
            *PYTHON,
            "run",
            "luidolt2020",
            "--simulate",
            "--participant",
            "P01",
            "--out",
            str(out),
            "--trial-delay-ms",
            "300",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        csvs = list(out.glob("*.csv")) if out.exists() else []
        if csvs and len(csvs[0].read_text().splitlines()) >= 3:  # the header and two trials
            break
        time.sleep(0.05)
    # Taken away in one step, as a file manager's delete does: a tree removed file by file
    # races the session, which writes its trials back into the folder while it is emptied.
    gone = out.rename(tmp_path / "trash")
    shutil.rmtree(gone)
    _, err = process.communicate(timeout=300)
    assert process.returncode != 0, err
    assert "completed" not in err.splitlines()[-1], err
    assert "removed" in err and "Traceback" not in err, err
    (csv,) = out.glob("P01_luidolt2020_s1_*.csv")
    lines = csv.read_text().splitlines()
    assert len(lines) >= 3
    assert [line.split(",")[3] for line in lines[1:]] == [str(i) for i in range(1, len(lines))]
