"""The planner chooses the fastest of its paths with the costs measured on this machine: forced
on each path in turn, the renders are timed in alternating rounds (each round starting one
renderer later, each timed render just after an untimed one of its own: a forced path run
right after the planner's choice of it would find its kernel and memory warm), and the
planner's render, its plan included, is within 1.2× of the fastest path that keeps the
tolerance (medians of the rounds, so that a busy moment of a shared machine falls on every
path alike).

The planner's render is its own plan, timed, and the execution of the path it chose, timed
on the renderer forced on that path (its render less its plan): two renderers carrying out
the same plan, the same functions called as often (profiled), were 4-16 % apart in three
runs on the quiet machine (8.94-9.95 ms against 8.33-9.58 ms on two lamps and a glint, 27
rounds each), a difference of the renderer object's memory that stays with it for the
run, which no number of rounds averages out and which is no part of the planner's choice.
The planner's plan is timed on its own renderer: what its evaluation of every path costs
is charged to it."""

import json
import os
import time

import numpy as np
import pytest

from glarelab.bench.scenes import lamps_scene
from glarelab.glare import VosGlare
from glarelab.glare.models.cache import KernelCache
from glarelab.glare.rendering.costs import PathCosts, cores, machine_costs
from glarelab.glare.rendering.renderer import GlareRenderer

ROUNDS = 9
SLOWEST_RATIO = 1.2  # issue 35: the planner's choice within 1.2× of the fastest path


def test_costs_are_measured_once_and_kept(tmp_path):
    first = machine_costs(tmp_path)
    stored = tmp_path / f"costs-{cores()}-threads.json"
    assert stored.is_file() and json.loads(stored.read_text())["threads"] == cores()
    assert machine_costs(tmp_path) == first  # read back, not measured again
    assert all(value > 0 for value in vars(first).values())
    stored.write_text("{not json")  # a damaged file is measured again and replaced
    assert isinstance(machine_costs(tmp_path), PathCosts)
    assert json.loads(stored.read_text())["version"] >= 1
    with pytest.raises(ValueError, match="costs must be"):
        GlareRenderer(VosGlare(), pixel_deg=0.05, shape=(8, 8), costs="quiet")


def test_the_direct_spread_is_costed_at_512_squared_and_by_its_share_beyond(monkeypatch):
    """A direct spread's time is a part that grows with its output and a part that does not
    (its threads, its windows). Costed per pixel over 512² alone, the fixed part was charged
    on every pixel of a larger output: the 2048² night scene's direct spread was put at 1.6
    times its time, a tie with the FFT, which took 1.5 times as long; costed by the extra
    time of a wider output alone, small scenes took the direct path at 1.2-1.5 times the
    FFT's time. With spreads (on a clock of their own) whose fixed part is twice their
    per-pixel work at 512², the costs keep the per-pixel costs at 512² in their ratios
    (to 1e-4: the fake spreads' own time) and find the share of each further pixel, 1/3;
    the FFT's rounds scale them all alike."""
    from glarelab.glare.rendering import _convolve, costs

    side = costs.DIRECT_COST_SIDE
    pixel_s, correlate_s, weight_s, span32_s, fixed = 2e-6, 5e-6, 4e-7, 1e-6, 2.0
    spent = [0.0]

    def direct_spread(
        points, centre, kernel, out_box, into, *, quadrant, workers, groups=None,
        method="cheapest", precision="float64",
    ):  # fmt: skip
        area = (out_box[1] - out_box[0]) * (out_box[3] - out_box[2])
        if method == "spans":  # per value a span runs over
            values = _convolve.span_values(
                out_box[3] - out_box[2], points.shape[1] - 1, kernel.shape[1] - 1
            )
            rate = (pixel_s if precision == "float64" else span32_s) * points.size * values
        else:
            rate = correlate_s + weight_s * points.size
        spent[0] += rate * (fixed * side**2 + area)
        return into

    class Clock:
        @staticmethod
        def perf_counter():
            return time.perf_counter() + spent[0]

    monkeypatch.setattr(_convolve, "direct_spread", direct_spread)
    monkeypatch.setattr(costs, "time", Clock)
    measured = costs.measure_costs()
    assert measured.direct_wide_share == pytest.approx(1 / (1 + fixed), rel=1e-4)
    scale = measured.direct_pixel_s / (pixel_s * (1 + fixed))  # the FFT's rounds
    assert 0.3 < scale <= 1.0 + 1e-4, scale
    for name, value in (
        ("correlate_s", correlate_s),
        ("correlate_weight_s", weight_s),
        ("span32_pixel_s", span32_s),
    ):
        ratio = getattr(measured, name) / measured.direct_pixel_s
        assert ratio == pytest.approx(value / pixel_s, rel=1e-4), name


@pytest.mark.parametrize(
    "damage",
    [
        {"direct_wide_share": "0.5"},
        {"direct_wide_share": None},
        {"direct_wide_share": 0.05},
        {"correlate_s": -1e-8},
        {"fft_s": float("nan")},
        {"span32_pixel_s": float("inf")},
        {"threads": 0},
        {"threads": True},
    ],
)
def test_a_stored_cost_no_calibration_makes_is_measured_again(tmp_path, monkeypatch, damage):
    """A costs file of this version whose numbers are not what a calibration makes (a string,
    null, a share outside its limits, a negative, NaN or infinite cost, no threads) is measured
    again: a share stored as "0.5" made the plan multiply a string by the image's pixels."""
    from dataclasses import asdict

    from glarelab.glare.rendering import costs

    fresh = PathCosts(fft_s=1.25e-9)
    monkeypatch.setattr(costs, "measure_costs", lambda: fresh)
    stored = tmp_path / f"costs-{cores()}-threads.json"
    good = asdict(PathCosts()) | {"version": costs.COSTS_VERSION}
    stored.write_text(json.dumps(good))
    assert machine_costs(tmp_path) == PathCosts()  # read back as it was stored
    stored.write_text(json.dumps(good | damage))
    assert machine_costs(tmp_path) == fresh


def test_the_direct_estimate_is_never_below_its_quick_lower_bound():
    """With the clusters not looked for (the quick bound already over the limit), the plan
    keeps the bound; it must not exceed the estimate the clusters give, whatever the costs
    and however the clusters are spread (correlated or a span per pixel), in either precision."""
    from glarelab.glare.rendering.plan import _direct_cost
    from glarelab.glare.rendering.scene import Scene

    rng = np.random.default_rng(11)
    for _ in range(40):
        side = int(rng.integers(16, 2048))
        image = np.zeros((side, side))
        for _ in range(int(rng.integers(1, 6))):
            y, x = rng.integers(0, side - 6, 2)
            h, w = rng.integers(1, 6, 2)
            image[y : y + h, x : x + w] = np.where(rng.random((h, w)) < 0.7, 1e4, 0.0)
        image[side // 2, side // 2] = 1e4
        scene = Scene.of(image, 220.0, "Yoshida2008", np.float64)
        given = PathCosts(
            **{
                name: float(rng.uniform(0.1, 10.0) * 1e-9)
                for name in (
                    "direct_pixel_s", "correlate_s", "correlate_weight_s", "span32_pixel_s"
                )
            },
            direct_wide_share=float(rng.uniform(0.3, 1.0)),
        )  # fmt: skip
        reach = tuple(int(v) for v in rng.integers(1, 2 * side, 2))
        out = (0, side, 0, side)
        for precision in ("float64", "float32"):
            lowest = _direct_cost(scene, out, reach, 0.0, given, precision)
            exact = _direct_cost(scene, out, reach, np.inf, given, precision)
            assert lowest <= exact * (1 + 1e-12)


def _scene(name: str) -> tuple[np.ndarray, float]:
    if name == "two lamps and a glint":
        return lamps_scene((512, 512), 2, pixel_deg=0.04, glint_cd_m2=1e7)
    if name == "400 lamps":
        return lamps_scene((512, 512), 400, pixel_deg=0.04)
    if name == "a lit street":
        bright, pixel = lamps_scene((512, 512), 60, pixel_deg=0.04)
        return bright + 5.0, pixel  # a lit street: the dark end is far from black
    raise ValueError(f"unknown scene {name!r}")


NEAR_TIE = pytest.mark.xfail(
    reason="issue 35 item 2: a near tie of the direct path and the FFT (forced renders "
    "0.8-1.0 of each other from run to run); in 1 of 7 runs on the quiet machine the "
    "planner's FFT was 1.27x the direct path (docs/speed-accuracy.md)",
    strict=False,
)


@pytest.fixture(scope="module")
def timing_setup(tmp_path_factory):
    folder = tmp_path_factory.mktemp("costs")
    return KernelCache(folder), machine_costs(folder)


@pytest.mark.skipif(
    not os.environ.get("GLARELAB_TIME_PATHS"),
    reason="times every path (minutes on a loaded machine): set GLARELAB_TIME_PATHS=1",
)
@pytest.mark.parametrize(
    "name",
    [pytest.param("two lamps and a glint", marks=NEAR_TIE), "400 lamps", "a lit street"],
)
def test_the_planner_chooses_within_1_2x_of_the_fastest_path(timing_setup, name):
    cache, costs = timing_setup
    image, pixel = _scene(name)
    model = VosGlare()
    kernel = model.kernel(pixel, (1023, 1023))
    renderers = {
        label: GlareRenderer(
            model,
            pixel_deg=pixel,
            shape=image.shape,
            kernel=kernel,
            cache=cache,
            costs=costs,
            **({} if paths is None else {"paths": paths}),
        )
        for label, paths in (
            ("planner", None),
            ("direct", ("direct",)),
            ("fft", ("fft",)),
            ("multires", ("multires",)),
        )
    }
    kept = {}
    for label, renderer in renderers.items():  # made once: kernels, spectra, errors
        result = renderer.render(image)
        path = result.plan.path
        if label == "planner" or (path == label and not result.fallback):
            kept[label] = renderer  # a forced path that fell back is not that path
    times = {label: [] for label in kept}
    plans = {label: [] for label in kept}
    labels = list(kept)
    for index in range(ROUNDS):
        shift = index % len(labels)
        for label in labels[shift:] + labels[:shift]:
            # each timed render follows one of its own path: otherwise a forced path run just
            # after the planner's choice of it finds its kernel and memory warm
            kept[label].render(image)
            start = time.perf_counter()
            kept[label].plan(image)
            plans[label].append(time.perf_counter() - start)
            start = time.perf_counter()
            kept[label].render(image)
            times[label].append(time.perf_counter() - start)
    # medians, not per-round ratios to each round's fastest path: the least of three noisy
    # times is biased low, and a ratio to it biased high
    medians = {label: float(np.median(t)) for label, t in times.items()}
    planned = {label: float(np.median(t)) for label, t in plans.items()}
    chosen = renderers["planner"].plan(image).path
    planner = (  # its own plan, and its path's execution (module docstring)
        planned["planner"] + medians[chosen] - planned[chosen]
        if chosen in kept
        else medians["planner"]
    )
    ratio = planner / min(v for k, v in medians.items() if k != "planner")
    assert ratio <= SLOWEST_RATIO, (name, chosen, ratio, planner, medians, planned)
