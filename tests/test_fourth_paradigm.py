"""A paradigm touches one module per layer: a fourth one, defined only here, runs end to end.

The paradigm (a yes/no glow detection task: one image of a disk with glare at one of several
source luminances, "does the disk glow?") is registered in each layer's registry through its
public registration function: its contract (protocol keys and CSV columns), its stimuli, its
engine and simulated observer, and its analysis. Its protocol is a TOML file written to a
temporary folder; the demo then builds its stimulus set, checks how the first trial is drawn,
runs simulated sessions through the session loop and writes the report, without any other file
of the suite knowing the paradigm. A paradigm missing from one registry fails loudly, naming
the registry.
"""

from __future__ import annotations

import json
import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from glarelab.analysis import paradigms as analysis_paradigms
from glarelab.analysis.dataset import Design
from glarelab.experiments import paradigms as experiments_paradigms
from glarelab.experiments.engine import Engine, LookingObserver, participant_rng
from glarelab.experiments.layout import protocol_drawing
from glarelab.observers.fitted_range import (
    JudgedGlare,
    JudgedStimuli,
    OutsideFittedRangeWarning,
    judged_background,
)
from glarelab.protocols import Key, load_protocol, pixel_deg
from glarelab.protocols import core as protocols_core
from glarelab.protocols.columns import Column
from glarelab.protocols.common import DISPLAY, INSTRUCTIONS, VIEWING, glare_model
from glarelab.stimuli import paradigms as stimuli_paradigms
from glarelab.stimuli.shapes import ImageRow

NAME = "detection"
SIZE_PX = 61  # each image's side; the disk at its centre pixel
PROTOCOL = """
[study]
name = "detection_demo"
paradigm = "detection"
title = "Does the disk glow? A paradigm defined in a test"
seed = 11

[display]
name = "a test display"
resolution_px = [1024, 768]
diagonal_in = 20.0
max_cd_m2 = 300.0
black_cd_m2 = 0.5
bit_depth = 8

[viewing]
distance_m = 1.0
room_lux = 60.0

[instructions]
text = "Press y when the disk glows, n when it does not."

[stimulus]
disk_deg = 0.3
background_cd_m2 = 0.0  # a black field, as the observers were fitted on (Spencer 1995 §4)

[glare]
model = "gaussian"
parameters = { sigma_deg = 0.34 }
clamp_cd_m2 = 220.0
labels = ["none", "weak", "strong"]
levels_cd_m2 = [220.0, 1500.0, 6000.0]

[trials]
repeats = 2
"""


# --- protocols: the contract -------------------------------------------------------------


def _contract() -> SimpleNamespace:
    schema = {
        "display": DISPLAY,
        "viewing": VIEWING,
        "instructions": INSTRUCTIONS,
        "stimulus": {
            "disk_deg": Key(float, "the disk's diameter", unit="deg", low=0.01, high=5.0),
            "background_cd_m2": Key(float, "the uniform background", unit="cd/m²", low=0.0),
        },
        "glare": {
            "model": Key(str, "a glare model"),
            "parameters": Key(dict, "the model's parameters", default={}),
            "clamp_cd_m2": Key(float, "the display clamp", unit="cd/m²", low=1.0),
            "labels": Key(list, "level labels", item=str, length=(1, 10), token=True),
            "levels_cd_m2": Key(list, "source luminances", unit="cd/m²", item=float, low=0.0),
        },
        "trials": {"repeats": Key(int, "each level shown this often", low=1, high=20)},
        "observer": Key(dict, "the simulated observers' parameters", default={}),
    }

    def check(validated: dict, problems: list[str], folder) -> None:
        glare = validated["glare"]
        if len(glare["labels"]) != len(glare["levels_cd_m2"]):
            problems.append("glare: one label per level")

    def columns(protocol) -> tuple[Column, ...]:
        labels = tuple(protocol["glare"]["labels"])
        return (
            Column("level", str, "the glare level shown", choices=labels),
            Column("glows", bool, "the answer: the disk glows"),
        )

    return SimpleNamespace(SCHEMA=schema, check=check, columns=columns, SESSION_ORDER=())


# --- stimuli -----------------------------------------------------------------------------


def _build(protocol, *, progress=None) -> dict:
    s, g = protocol["stimulus"], protocol["glare"]
    pixel = pixel_deg(protocol)
    y, x = np.indices((SIZE_PX, SIZE_PX))
    centre = SIZE_PX // 2
    disk = np.hypot(y - centre, x - centre) * pixel <= s["disk_deg"] / 2
    model = glare_model(g["model"], g["parameters"])
    from glarelab.glare import render_glare

    images = {}
    for label, level in zip(g["labels"], g["levels_cd_m2"], strict=True):
        scene = np.where(disk, level, s["background_cd_m2"])
        shown = render_glare(scene, model, pixel_deg=pixel, l_dmax_cd_m2=g["clamp_cd_m2"])
        images[f"disk_{label}"] = {
            "img": shown.image,
            "kind": "glare",
            "model": g["model"],
            "label": label,
        }
    geometry = {
        "pixel_deg": pixel,
        "centre_px": [centre, centre],
        "disk_diameter_deg": s["disk_deg"],
    }
    return {"images": images, "geometry": geometry, "parameters": {"pixel_deg": pixel}}


def _first_row(protocol, display_pixel_deg: float) -> ImageRow:
    return ImageRow([(SIZE_PX, SIZE_PX)], 0)


STIMULI = stimuli_paradigms.ParadigmStimuli(
    _build, _first_row, ("glare", "model"), stimuli_paradigms.always_shows,
    stimuli_paradigms.no_backgrounds, stimuli_paradigms.no_kernels,
)  # fmt: skip


# --- experiments: engine and simulated observer --------------------------------------------


class DetectionEngine(Engine):
    def __init__(self, protocol, participant, *, session=1, counterbalance=None, refresh_hz=60.0):
        self.protocol, self.study = protocol, protocol.study
        self.participant, self.session = participant, session
        labels = protocol["glare"]["labels"] * protocol["trials"]["repeats"]
        order = participant_rng(protocol.seed, participant, "order").permutation(len(labels))
        self.trials = [labels[i] for i in order]
        self.index, self.phase = 0, "instructions"

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def total_trials(self) -> int:
        return len(self.trials)

    def screen(self) -> dict:
        if self.phase == "instructions":
            text = self.protocol["instructions"]["text"]
            return {"kind": "instructions", "text": text, "keys": {"space": "start"}}
        if self.phase == "done":
            return {"kind": "done", "keys": {}}
        label = self.trials[self.index]
        return {
            "kind": "judge",
            "trial": self.index + 1,
            "images": [{"role": "disk", "terms": [[f"disk_{label}", 1.0]]}],
            "keys": {"y": "it glows", "n": "it does not"},
        }

    def press(self, key: str, t: float = 0.0) -> dict | None:
        if self.phase == "instructions":
            self.phase = "judge" if key == "space" else self.phase
            return None
        if self.phase != "judge" or key not in ("y", "n"):
            return None
        row = {
            "study": self.study,
            "participant": self.participant,
            "session": self.session,
            "trial": self.index + 1,
            "block": "main",
            "time_s": t,
            "level": self.trials[self.index],
            "glows": key == "y",
        }
        self.index += 1
        self.phase = "judge" if self.index < len(self.trials) else "done"
        return row

    def replay(self, rows: list[dict]) -> None:
        self.index = len(rows)
        if rows:
            self.phase = "judge" if self.index < len(self.trials) else "done"


class DetectionObserver(LookingObserver):
    @staticmethod
    def judged(protocol, geometry: dict) -> JudgedStimuli:
        g = protocol["glare"]
        ratios = tuple(level / g["clamp_cd_m2"] for level in g["levels_cd_m2"])
        method = JudgedGlare("glare", g["model"], g["parameters"], ratios)
        field = {"kind": "uniform", "cd_m2": protocol["stimulus"]["background_cd_m2"]}
        background = judged_background(
            "background",
            field,
            disk_cd_m2=g["clamp_cd_m2"],
            black_cd_m2=protocol["display"]["black_cd_m2"],
        )
        return JudgedStimuli(
            (method,),
            g["clamp_cd_m2"],
            geometry["disk_diameter_deg"],
            backgrounds=(background,),
            pixel_deg=geometry["pixel_deg"],
            bit_depth=protocol["display"]["bit_depth"],
            room_lux=protocol["viewing"]["room_lux"],
        )

    def keys(self, screen: dict) -> list[tuple[str, float]]:
        g = self.display.geometry
        percept = self.display.percept(
            self.model,
            screen["images"][0]["terms"],
            centre_px=tuple(g["centre_px"]),
            diameter_deg=g["disk_diameter_deg"],
            pixel_deg=g["pixel_deg"],
        )
        rng = participant_rng(self.protocol.seed, self.participant, f"trial {screen['trial']}")
        glows, _, _ = self.observer.answers(percept, percept, rng)
        return [("y" if glows else "n", 0.7)]


RUN = experiments_paradigms.Paradigm(DetectionEngine, DetectionObserver)


# --- analysis --------------------------------------------------------------------------------


def _design(protocol) -> Design:
    labels = protocol["glare"]["labels"]
    return Design(("level",), tuple((label,) for label in labels), "main", ("main",), False)


def _tests(dataset, protocol) -> dict[str, pd.DataFrame]:
    trials = dataset.trials
    share = trials.groupby("level", sort=False)["glows"].mean()
    order = [label for label in protocol["glare"]["labels"] if label in share.index]
    return {"glows": share.loc[order].rename("share_yes").reset_index()}


def _analyse(dataset, protocol) -> dict:
    table = _tests(dataset, protocol)["glows"]
    text = {row.level: f"{100 * row.share_yes:.0f} % yes" for row in table.itertuples()}
    return {"tables": {"glows": table}, "figures": {}, "text": text}


ANALYSIS = SimpleNamespace(
    design=_design,
    check=lambda trials, protocol: [],
    flags=lambda trials, protocol: [],
    tests=_tests,
    analyse=_analyse,
    methods=lambda protocol, participants, who: f"{who} said whether each disk glowed.",
    stimulus_figures=None,
)

REGISTRIES = {
    "protocols": (protocols_core.PARADIGMS, protocols_core.register_paradigm, _contract),
    "stimuli": (stimuli_paradigms.PARADIGMS, stimuli_paradigms.register_paradigm, lambda: STIMULI),
    "experiments": (
        experiments_paradigms.PARADIGMS,
        experiments_paradigms.register_paradigm,
        lambda: RUN,
    ),
    "analysis": (
        analysis_paradigms.PARADIGMS,
        analysis_paradigms.register_paradigm,
        lambda: ANALYSIS,
    ),
}


def _register(monkeypatch, *, without: str | None = None) -> None:
    """Register the paradigm in every layer (but ``without``); removed after the test."""
    for layer, (registry, register, entry) in REGISTRIES.items():
        if layer == without:
            continue
        monkeypatch.setitem(registry, NAME, None)  # so that it is removed after the test
        del registry[NAME]
        register(NAME, entry())


@pytest.fixture
def protocol_file(tmp_path):
    path = tmp_path / "detection_demo.toml"
    path.write_text(PROTOCOL)
    return path


def test_a_fourth_paradigm_runs_end_to_end(monkeypatch, protocol_file, tmp_path):
    from glarelab.demo import run_demo

    _register(monkeypatch)
    protocol = load_protocol(protocol_file)
    assert protocol.paradigm == NAME
    lines, exact = protocol_drawing(protocol)
    assert exact and lines[0].startswith("drawn 1:1 on the display's 1024 × 768 px: 1 image")
    with warnings.catch_warnings():
        warnings.simplefilter("error", OutsideFittedRangeWarning)  # inside the fitted range
        report = run_demo(
            protocol_file, tmp_path / "demo", participants=3, seed=2, log=lambda s: 0
        )
    out = tmp_path / "demo"
    manifest = json.loads((out / "stimuli" / "manifest.json").read_text())
    assert manifest["paradigm"] == NAME
    assert manifest["plots"] == ["profiles_gaussian.png"]  # the profile plots of its groups
    csvs = sorted((out / "data").glob("*.csv"))
    assert len(csvs) == 3
    rows = pd.read_csv(csvs[0])
    assert list(rows.columns[-2:]) == ["level", "glows"]
    assert len(rows) == 6 and set(rows["level"]) == {"none", "weak", "strong"}
    table = pd.read_csv(out / "report" / "glows.csv").set_index("level")["share_yes"]
    # the glare-free disk mostly does not glow, the strongest glare does (as in Yoshida 2008
    # Table 1: 0 % at A, 100 % at the highest levels)
    assert table["none"] < 0.5 and table["strong"] == 1.0
    assert "said whether each disk glowed" in report.read_text()


def test_its_observers_warn_outside_the_fitted_range(monkeypatch, protocol_file, tmp_path):
    from glarelab.demo import run_demo

    _register(monkeypatch)
    protocol_file.write_text(PROTOCOL.replace("disk_deg = 0.3", "disk_deg = 0.6"))
    with pytest.warns(OutsideFittedRangeWarning, match=r"disk diameter 0\.6°"):
        run_demo(protocol_file, tmp_path / "demo", participants=2, seed=2, log=lambda s: 0)


@pytest.mark.parametrize(
    "layer, message",
    [
        ("protocols", r"study\.paradigm = 'detection': must be one of"),
        ("stimuli", r"no stimuli registered in glarelab\.stimuli\.paradigms\.PARADIGMS"),
        ("experiments", r"no engine registered in glarelab\.experiments\.paradigms\.PARADIGMS"),
        ("analysis", r"no analysis registered in glarelab\.analysis\.paradigms\.PARADIGMS"),
    ],
)
def test_a_missing_registry_entry_fails_loudly(
    monkeypatch, protocol_file, tmp_path, layer, message
):
    from glarelab.demo import run_demo

    _register(monkeypatch, without=layer)
    with pytest.raises(Exception, match=message):
        run_demo(protocol_file, tmp_path / "demo", participants=2, seed=2, log=lambda s: 0)


def test_a_missing_stimuli_entry_stops_the_layout_check(monkeypatch, protocol_file):
    _register(monkeypatch, without="stimuli")
    with pytest.raises(ValueError, match="no stimuli registered"):
        protocol_drawing(load_protocol(protocol_file))


def test_incomplete_entries_are_refused_at_registration():
    with pytest.raises(ValueError, match="lacks stimulus_figures"):
        analysis_paradigms.register_paradigm(
            NAME,
            SimpleNamespace(
                **{k: v for k, v in vars(ANALYSIS).items() if k != "stimulus_figures"}
            ),
        )
    with pytest.raises(ValueError, match="lacks columns"):
        protocols_core.register_paradigm(NAME, SimpleNamespace(SCHEMA={}, check=print))
    with pytest.raises(ValueError, match="must be a subclass"):
        experiments_paradigms.register_paradigm(NAME, experiments_paradigms.Paradigm(object))
    with pytest.raises(ValueError, match="already registered"):
        stimuli_paradigms.register_paradigm("matching", STIMULI)

    class Blind(LookingObserver):  # looks at images but does not say what it judges
        def keys(self, screen):
            return []

    with pytest.raises(TypeError, match="judged"):
        Blind(None, "p", seed=1, stimuli=None)
    for registry, _, _ in REGISTRIES.values():
        assert NAME not in registry


def test_a_contract_must_name_its_session_order():
    contract = _contract()
    del contract.SESSION_ORDER
    with pytest.raises(ValueError, match="lacks SESSION_ORDER"):
        protocols_core.register_paradigm(NAME, contract)
    contract.SESSION_ORDER = ("block_order",)  # not a field a sidecar has
    with pytest.raises(ValueError, match=r"lacks SESSION_ORDER .*counterbalance, trial_order"):
        protocols_core.register_paradigm(NAME, contract)
    assert NAME not in protocols_core.PARADIGMS
