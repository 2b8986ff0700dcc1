"""The parts of the benchmark that need new processes: one ``add_glare`` call in a fresh
process (with an empty and a warm kernel cache), the start-up of ``glarelab``, and the peak
memory of one render."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from glarelab import glare
from glarelab.bench.peers import PEER, PEER_SPECTRUM, fftconvolve_peer, spectrum_peer
from glarelab.bench.report import DEFAULT
from glarelab.bench.scenes import workload
from glarelab.glare.models.digitise import kernel_shape_for

__all__ = [
    "FRESH_EMPTY",
    "FRESH_WARM",
    "FRESH_WORKLOADS",
    "MEMORY_WORKLOADS",
    "STARTUP_BASELINE",
    "STARTUP_CASES",
    "fresh_bench",
    "memory_bench",
    "startup_bench",
]

MEMORY_WORKLOADS = ("leaves_2048", "night_sun_2048")  # peak memory, in separate processes
FRESH_WORKLOADS = ("night_sun_2048",)  # the one-call workload, timed in fresh processes
FRESH_EMPTY = "add_glare, one call, fresh process, empty kernel cache"
FRESH_WARM = "add_glare, one call, fresh process, warm kernel cache"
_FRESH_CALL = """
import sys, time
import numpy as np
from glarelab import glare
from glarelab.bench.scenes import CALIBRATION, L_DMAX, bench_model, workload
from glarelab.display.calibration import Calibration

name, model_name, out = sys.argv[1:4]
image, pixel = workload(name)
model = bench_model(model_name, pixel)
lut = Calibration.load(CALIBRATION).lut
start = time.perf_counter()
result = glare.add_glare(image, model, pixel_deg=pixel, l_dmax_cd_m2=L_DMAX, display=lut)
seconds = time.perf_counter() - start
np.save(out, result)
print(repr(seconds))
"""


def _fresh_call(
    name: str, model_name: str, cache_dir: Path, out: Path
) -> tuple[float, np.ndarray]:
    """One ``add_glare`` in a new Python process whose kernel cache is ``cache_dir``: the
    seconds of the call alone (the process's start-up is timed by :func:`startup_bench`)."""
    import os
    import subprocess
    import sys

    root = str(Path(__file__).resolve().parents[2])
    path = os.environ.get("PYTHONPATH")
    env = {**os.environ, "GLARELAB_CACHE": str(cache_dir), "PYTHONPATH": root}
    env.pop("GLARELAB_NO_CACHE", None)
    if path:
        env["PYTHONPATH"] = os.pathsep.join([root, path])
    done = subprocess.run(
        [sys.executable, "-c", _FRESH_CALL, name, model_name, str(out)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"the fresh-process call failed:\n{done.stderr}")
    return float(done.stdout.strip().splitlines()[-1]), np.load(out)


def fresh_bench(name: str, model_name: str, repeats: int, log=print) -> dict:
    """The one-call workload: ``add_glare`` in a fresh process with an empty kernel cache
    (a new folder each time) and with a warm one (filled by an earlier process); the best
    of ``repeats`` each, and the last image of each.

    Parameters
    ----------
    name
        The workload (:func:`glarelab.bench.scenes.workload`).
    model_name
        The model (:func:`glarelab.bench.scenes.bench_model`).
    repeats
        Fresh processes per case, the fastest kept.
    log
        Called with a line per measurement; default :func:`print`.

    Returns
    -------
    dict
        Case (empty or warm cache) → ``(seconds, image)``: the best wall time of the call,
        and the image, cd/m².
    """
    import tempfile

    results = {}
    with tempfile.TemporaryDirectory(prefix="glarelab-bench-") as folder:
        folder = Path(folder)
        empty = []
        for index in range(repeats):
            seconds, image = _fresh_call(
                name, model_name, folder / f"empty{index}", folder / "out.npy"
            )
            empty.append(seconds)
            log(f"  fresh process, empty cache: {seconds:.3f} s")
        results[FRESH_EMPTY] = (min(empty), image)
        warm = []
        for _ in range(repeats):
            seconds, image = _fresh_call(name, model_name, folder / "empty0", folder / "out.npy")
            warm.append(seconds)
            log(f"  fresh process, warm cache: {seconds:.3f} s")
        results[FRESH_WARM] = (min(warm), image)
    return results


STARTUP_BASELINE = "import numpy, scipy.fft"
STARTUP_CASES = {  # label → Python code, or None for the console command
    STARTUP_BASELINE: "import numpy, scipy.fft",
    "from glarelab import glare": "from glarelab import glare",
    "glarelab --version": None,
}


def _import_seconds(code: str) -> float:
    """Seconds of the imports in ``code`` in a new interpreter (``python -X importtime``:
    the sum of the top-level imports' cumulative times)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env=_source_env(),
    )
    total = 0
    for line in done.stderr.splitlines():
        if not line.startswith("import time:") or "|" not in line:
            continue
        fields = line.split("|")
        if fields[-1].startswith(" ") and not fields[-1].startswith("  "):  # top level
            try:
                total += int(fields[1])
            except ValueError:  # the header line
                continue
    return total * 1e-6


def _source_env() -> dict:
    import os

    root = str(Path(__file__).resolve().parents[2])
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([root, path]) if path else root}


def _wall_seconds(arguments: list[str]) -> float:
    import subprocess
    import sys

    start = time.perf_counter()
    subprocess.run(
        [sys.executable, *arguments], capture_output=True, check=True, env=_source_env()
    )
    return time.perf_counter() - start


def startup_bench(repeats: int = 5, log=print) -> list[dict]:
    """Start-up: the imports of ``import numpy, scipy.fft``, ``from glarelab import glare`` and
    ``glarelab --version`` (``python -X importtime``), and each process's wall time; the
    median of ``repeats`` runs, the cases in turn, with each case's ratio to numpy and
    scipy.fft (the median of the per-round ratios).

    Parameters
    ----------
    repeats
        Rounds of the three cases; default 5.
    log
        Called with a line per measurement; default :func:`print`.

    Returns
    -------
    list of dict
        One row per case: ``case``, ``import_s`` and ``process_s`` (medians, seconds),
        ``import_ratio`` and ``process_ratio`` (to the numpy and scipy.fft baseline).
    """
    rounds = []
    for _ in range(repeats):
        measured = {}
        for label, code in STARTUP_CASES.items():
            if code is None:
                imports = _import_seconds("from glarelab.cli import main")
                wall = _wall_seconds(["-m", "glarelab", "--version"])
            else:
                imports = _import_seconds(code)
                wall = _wall_seconds(["-c", code])
            measured[label] = (imports, wall)
        rounds.append(measured)
    rows = []
    for label in STARTUP_CASES:
        imports = [r[label][0] for r in rounds]
        walls = [r[label][1] for r in rounds]
        ratios = [r[label][0] / r[STARTUP_BASELINE][0] for r in rounds]
        wall_ratios = [r[label][1] / r[STARTUP_BASELINE][1] for r in rounds]
        rows.append(
            {
                "case": label,
                "import_s": float(np.median(imports)),
                "process_s": float(np.median(walls)),
                "import_ratio": float(np.median(ratios)),
                "process_ratio": float(np.median(wall_ratios)),
            }
        )
        log(
            f"  {label}: imports {rows[-1]['import_s']:.3f} s ({rows[-1]['import_ratio']:.2f}×), "
            f"process {rows[-1]['process_s']:.3f} s ({rows[-1]['process_ratio']:.2f}×)"
        )
    return rows


def memory_bench(name: str, log=print) -> list[dict]:
    """Peak memory (MiB) of one Vos render of a workload, allocated through Python and NumPy
    (``tracemalloc``; FFT scratch inside pocketfft is not counted) on top of the image and the
    digitised kernel: ours (renderer built with the kernel, then one render) and the two FFT
    peers (their kernel spectrum included).

    Parameters
    ----------
    name
        The workload (:func:`glarelab.bench.scenes.workload`).
    log
        Called with a line per measurement; default :func:`print`.

    Returns
    -------
    list of dict
        One row per contender: ``workload``, ``variant`` and ``peak_mib``.
    """
    import tracemalloc

    image, pixel = workload(name)
    model = glare.VosGlare()
    kernel = model.kernel(pixel, kernel_shape_for(image.shape))
    contenders = {
        DEFAULT: lambda: glare.GlareRenderer(
            model, pixel_deg=pixel, shape=image.shape, kernel=kernel
        ).render(image),
        PEER_SPECTRUM: lambda: spectrum_peer(image, kernel.values, np.float64)(),
        PEER: lambda: fftconvolve_peer(image, kernel.values)(),
    }
    rows = []
    for label, contender in contenders.items():
        tracemalloc.start()
        try:
            contender()
            mib = tracemalloc.get_traced_memory()[1] / 2**20
        finally:
            tracemalloc.stop()
        rows.append({"workload": name, "variant": label, "peak_mib": mib})
        log(f"  memory, {label}: {mib:.0f} MiB")
    return rows
