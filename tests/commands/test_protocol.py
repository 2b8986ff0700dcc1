"""``glarelab protocol check`` refuses the backgrounds a build would refuse, naming the key:
an EXR too small for the field, holding NaN, or brighter than where glare is added passed the
check, and the build then refused it."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from glarelab.cli import main
from glarelab.protocols import parse_protocol
from glarelab.stimuli.exr import write_exr
from glarelab.stimuli.matching import build_matching

PROTOCOLS = Path(__file__).parents[2] / "src" / "glarelab" / "protocols"


def _nan_exr(path: Path) -> None:
    import OpenEXR

    image = np.full((64, 64), 50.0, np.float32)
    image[3, 3] = np.nan
    header = {"type": OpenEXR.scanlineimage, "compression": OpenEXR.ZIP_COMPRESSION}
    OpenEXR.File(header, {"Y": image}).write(str(path))


def _glint_exr(path: Path) -> None:
    image = np.full((400, 400), 50.0, np.float32)
    image[200, 200] = 5e4  # above the glare's l_dmax of 220 cd/m²
    write_exr(path, image)


FILES = {
    "small": (lambda p: write_exr(p, np.full((64, 64), 50.0, np.float32)), 0.01, "covers 0.64°"),
    "nan": (_nan_exr, 0.05, "holds NaN or Inf"),
    "glint": (_glint_exr, 0.06, "above 220 cd/m² where glare is added"),
}


def _protocol(tmp_path: Path, study: str, background: dict) -> Path:
    """The shipped study with ``background`` (a uniform context's, for a staircase)."""
    text = (PROTOCOLS / f"{study}.toml").read_text(encoding="utf-8")
    inline = ", ".join(f"{k} = {v!r}".replace("'", '"') for k, v in background.items())
    if study == "spencer1995":
        text = text.replace('background = { kind = "uniform", cd_m2 = 0.0 }',
                            f"background = {{ {inline} }}")  # fmt: skip
    else:
        start = text.index("[background]")
        end = text.index("\n[", start + 1)
        text = text[:start] + "[background]\n" + inline.replace(", ", "\n") + text[end:]
    path = tmp_path / f"{study}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _check(path: Path, capsys) -> tuple[int, str]:
    capsys.readouterr()
    try:
        status = main(["protocol", "check", str(path)])
    except SystemExit as stop:
        status = stop.code
    return status, capsys.readouterr().err


@pytest.mark.parametrize("name", FILES)
def test_a_background_the_build_refuses_is_refused_by_the_check(name, tmp_path, capsys):
    make, file_deg, named = FILES[name]
    make(tmp_path / f"{name}.exr")
    background = {"kind": "exr", "path": f"{name}.exr", "pixel_deg": file_deg}
    path = _protocol(tmp_path, "yoshida2008", background)
    status, err = _check(path, capsys)
    assert status == 2 and "  - background: " in err and named in err, err
    assert "Traceback" not in err
    protocol = parse_protocol(tomllib.loads(path.read_text()), folder=tmp_path)
    with pytest.raises(ValueError) as built:  # the build's own words, after the key
        build_matching(protocol)
    assert f"background: {built.value}" in err


def test_a_staircase_contexts_background_is_named_by_its_context(tmp_path, capsys):
    write_exr(tmp_path / "small.exr", np.full((8, 8), 0.5, np.float32))
    background = {"kind": "exr", "path": "small.exr", "pixel_deg": 0.01}
    status, err = _check(_protocol(tmp_path, "spencer1995", background), capsys)
    assert status == 2 and "  - contexts[0].background: " in err and "covers 0.08°" in err, err


def test_a_file_covering_the_field_exactly_passes_and_builds(tmp_path, capsys):
    """16 pixels of 0.2° for Yoshida's 3.2° field: refused by the build as 'covers 3.2° ×
    3.2°, the stimulus needs 3.2° × 3.2°' (the field is 271 px, 3.204°)."""
    write_exr(tmp_path / "exact.exr", np.full((16, 16), 50.0, np.float32))
    background = {"kind": "exr", "path": "exact.exr", "pixel_deg": 0.2}
    path = _protocol(tmp_path, "yoshida2008", background)
    status, err = _check(path, capsys)
    assert status == 0, err
    protocol = parse_protocol(tomllib.loads(path.read_text()), folder=tmp_path)
    field = build_matching(protocol)["images"]["background"]["img"]
    np.testing.assert_allclose(field, 50.0, rtol=1e-12)


def test_keys_of_a_protocol_that_is_refused_print_no_table(capsys):
    """``protocol keys ''`` printed the table's header, then the refusal."""
    assert main(["protocol", "keys", ""]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "keys '': empty (an unset shell variable?); give a " in (
        captured.err
    )  # named as the paradigm argument it is, not as a protocol file's path


def test_a_protocol_the_check_refuses_for_its_observer_is_not_built(tmp_path, capsys):
    """An unknown [observer] key: protocol check refused it, and stimuli build built it."""
    text = (PROTOCOLS / "yoshida2008.toml").read_text(encoding="utf-8")
    path = tmp_path / "p.toml"
    path.write_text(text + "\n[observer]\nbogus_param = 1.0\n", encoding="utf-8")
    for argv in (["protocol", "check", str(path)],
                 ["stimuli", "build", str(path), "--out", str(tmp_path / "set")]):  # fmt: skip
        capsys.readouterr()
        assert main(argv) == 2
        assert "observer: unknown key(s) bogus_param" in capsys.readouterr().err
    assert not (tmp_path / "set").exists()


def test_an_unknown_key_of_a_nested_parameter_table_is_named():
    """'Spectrum.__init__() got an unexpected keyword argument 'x''."""
    from glarelab.protocols.common import glare_model

    with pytest.raises(ValueError, match=r"^halo_spectrum\.x: not a key of halo_spectrum"):
        glare_model("vos", {"halo_spectrum": {"x": 1}})


def _edited(tmp_path: Path, study: str, old: str, new: str) -> Path:
    text = (PROTOCOLS / f"{study}.toml").read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / f"{study}.toml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def test_a_kernel_the_build_refuses_is_refused_by_the_check(tmp_path, capsys):
    """Luidolt's wave-optics method with its Fresnel term at a 6 mm pupil passed the check; the
    build refused its aperture grid after rendering the methods before it."""
    from glarelab.stimuli.matching import matching_kernels

    path = _edited(tmp_path, "glare_methods2026", "particles = 1000, seed = 2026 }",
                   "particles = 1000, seed = 2026, fresnel = true }")  # fmt: skip
    status, err = _check(path, capsys)
    assert status == 2 and "Traceback" not in err, err
    assert "  - glare.methods[3].parameters: the aperture grid would need 8748² samples" in err
    assert "a fresnel_distance_mm above 24 (the pixels do not set this grid)" in err
    protocol = parse_protocol(tomllib.loads(path.read_text()), folder=tmp_path)
    use = matching_kernels(protocol)[3]
    with pytest.raises(ValueError) as built:  # the build's own words, after the key
        use.model.kernel(use.pixel_deg, use.shape)
    assert f"glare.methods[3].parameters: {built.value}" in err
    capsys.readouterr()  # and the build refuses it by key before rendering the others
    assert main(["stimuli", "build", str(path), "--out", str(tmp_path / "set")]) == 2
    err = capsys.readouterr().err
    assert "  - glare.methods[3].parameters: the aperture grid" in err and "1/20" not in err
    assert not (tmp_path / "set").exists() and not list(tmp_path.glob(".set.*"))


def test_spencers_renormalisation_of_a_window_too_small_for_the_halo_is_refused(tmp_path, capsys):
    """A 31-pixel window: the kernel held 1e-22 of the halo, which renormalisation made the
    whole halo; the check now refuses it as the kernel does."""
    from glarelab.stimuli.staircase import staircase_kernels

    path = _edited(tmp_path, "spencer1995", "window_px = 300 ", "window_px = 31 ")
    status, err = _check(path, capsys)
    assert status == 2 and "  - glare.parameters: normalisation='Spencer1995'" in err, err
    assert "holds under 1 % of the mesopic halo of a channel" in err
    protocol = parse_protocol(tomllib.loads(path.read_text()), folder=tmp_path)
    (use,) = staircase_kernels(protocol)
    with pytest.raises(ValueError, match="holds under 1 % of the mesopic halo"):
        use.model.kernel(use.pixel_deg, use.shape)
    shipped = _edited(tmp_path, "spencer1995", "window_px = 300 ", "window_px = 300 ")
    assert _check(shipped, capsys)[0] in (0, 1)  # 1: a drawing rounded on the display


def test_a_live_scene_whose_bank_the_model_cannot_make_is_refused(tmp_path, capsys):
    """A live scene with the wave-optics model passed the check; the session refused its
    aperture grid some two minutes in, after the calibration and the instructions, while the
    bank was made. The check, and the run before its window, refuse it by key."""
    from glarelab.glare.night.live import LiveNight
    from glarelab.protocols.rating import scene_glare_model
    from glarelab.stimuli.night import night_kernels, night_scene

    path = _edited(tmp_path, "luidolt2020-live", 'glare_model = "vos"', 'glare_model = "wave"')
    status, err = _check(path, capsys)
    assert status == 2 and "Traceback" not in err, err
    assert "  - scene.glare_model (the bank's 8 mm pupil): the aperture grid would need" in err
    protocol = parse_protocol(tomllib.loads(path.read_text()), folder=tmp_path)
    assert night_kernels(protocol)[-1].where == "scene.glare_model (the bank's 8 mm pupil)"
    street = night_scene(protocol)  # the session's bank: the same grid refused
    live = LiveNight(
        street["img"], pixel_deg=street["pixel_deg"], pupils_mm=(8.0,),
        glare_model=scene_glare_model(protocol["scene"]),
    )  # fmt: skip
    with pytest.raises(ValueError, match="the aperture grid would need 9262² samples"):
        live.prepare()
    capsys.readouterr()
    data = tmp_path / "data"
    assert main(["run", "--protocol", str(path), "--pilot", "--eyetracker", "mouse",
                 "--participant", "P1", "--out", str(data)]) == 2  # fmt: skip
    assert "scene.glare_model (the bank's 8 mm pupil)" in capsys.readouterr().err
    assert not data.exists()


def test_keys_of_neither_a_paradigm_nor_a_protocol_names_the_paradigms(capsys):
    # 'matchin' was refused listing the shipped protocols only, though a paradigm is allowed
    assert main(["protocol", "keys", "matchin"]) == 2
    err = capsys.readouterr().err
    assert "no protocol 'matchin'" in err and "or a paradigm: matching, staircase, rating" in err
