import json
import subprocess
import sys

import numpy as np
import pytest
from numpy.testing import assert_allclose
from PIL import Image

from glarelab import glare
from glarelab.cli import main
from glarelab.stimuli.exr import read_exr, write_exr
from glarelab.stimuli.shapes import disk


def yoshida_disk():
    return disk(
        field_deg=2.0,
        pixel_deg=0.02,
        disk_diameter_deg=0.3,
        disk_cd_m2=4000.0,
        background_cd_m2=150.0,
    )["img"].astype(np.float32)


@pytest.mark.parametrize("model", ["gaussian", "vos"])
def test_render_round_trips_a_float32_exr(tmp_path, model):
    image = yoshida_disk()
    source = write_exr(tmp_path / "in.exr", image)
    target, preview = tmp_path / "out.exr", tmp_path / "out.png"
    status = main(
        [
            "render",
            str(source),
            str(target),
            "--model",
            model,
            "--pixel-deg",
            "0.02",
            "--l-dmax",
            "220",
            "--preview",
            str(preview),
        ]
    )
    assert status == 0
    out = read_exr(target)
    assert out.dtype == np.float32 and out.shape == image.shape
    model_object = glare.GaussianGlare() if model == "gaussian" else glare.VosGlare()
    expected = glare.add_glare(image, model_object, pixel_deg=0.02, l_dmax_cd_m2=220.0)
    assert_allclose(out, expected.astype(np.float32), rtol=0)
    png = np.asarray(Image.open(preview))
    assert png.shape == image.shape and png.max() == 255


def test_render_says_exact_only_without_float32_round_off(tmp_path, capsys):
    """Every render of the whole kernel was called "(exact)", float32 transforms too."""
    source = write_exr(tmp_path / "in.exr", yoshida_disk())
    options = ["--pixel-deg", "0.02", "--explain"]
    for tolerance, label in (("0.5", "the whole kernel; error bound 0.0"), ("0", "(exact)")):
        target = tmp_path / f"out_{tolerance}.exr"
        assert (
            main(["render", str(source), str(target), *options, "--tolerance-codes", tolerance])
            == 0
        )
        err = capsys.readouterr().err
        done = next(line for line in err.splitlines() if "done in" in line)
        assert label in done, done


def test_render_many_files_into_a_folder_with_one_kernel(tmp_path, capsys):
    sources = []
    for level in (4000.0, 40000.0):
        image = yoshida_disk() * np.float32(level / 4000.0)
        sources.append(write_exr(tmp_path / f"disk_{level:g}.exr", image))
    out = tmp_path / "glare"
    assert main(["render", *map(str, sources), str(out), "--pixel-deg", "0.02"]) == 0
    for source in sources:
        expected = glare.add_glare(read_exr(source), glare.VosGlare(), pixel_deg=0.02)
        assert_allclose(read_exr(out / source.name), expected.astype(np.float32), rtol=0)
    err = capsys.readouterr().err  # the kernel is made (or read from the kernel cache) once
    assert err.count("digitising") + err.count("read from the cache") == 1


def test_render_accepts_rgb_and_mesopic_options(tmp_path):
    image = np.repeat(yoshida_disk()[..., None], 3, axis=2)
    source = write_exr(tmp_path / "rgb.exr", image)
    target = tmp_path / "rgb_out.exr"
    assert (
        main(
            [
                "render",
                str(source),
                str(target),
                "--regime",
                "mesopic",
                "--age",
                "40",
                "--flare-lines",
                "--seed",
                "3",
                "--pixel-deg",
                "0.02",
                "--composition",
                "Spencer1995",
                "--precision",
                "float32",
            ]
        )
        == 0
    )
    assert read_exr(target).shape == image.shape


def test_render_reports_bad_arguments_by_name(tmp_path, capsys):
    source = write_exr(tmp_path / "in.exr", yoshida_disk())
    with pytest.raises(SystemExit) as stop:  # argparse's refusal
        main(["render", str(source), str(tmp_path / "o.exr"), "--pixel-deg", "-1"])
    assert stop.value.code == 2
    assert "--pixel-deg: -1 must be a finite number in [1e-05, 10]" in capsys.readouterr().err
    assert (
        main(["render", str(tmp_path / "none.exr"), str(tmp_path / "o.exr"), "--pixel-deg", "1"])
        == 2
    )
    assert "none.exr: no such file" in capsys.readouterr().err


def test_looks_writes_exr_and_png_for_each_model(tmp_path):
    status = subprocess.run(
        [sys.executable, "-m", "glarelab", "looks", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )
    assert status.returncode == 0, status.stderr
    for name in ("gaussian", "vos_photopic", "vos_mesopic", "vos_scotopic_flare"):
        assert read_exr(tmp_path / f"{name}.exr").max() == pytest.approx(220.0)
        assert Image.open(tmp_path / f"{name}.png").size == (641, 641)
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["stimulus"]["disk_cd_m2"] == 4000.0
    assert (tmp_path / "profiles.png").stat().st_size > 10_000
    assert "[4/4]" in status.stderr


def test_looks_night_shows_each_effect_off_and_on(tmp_path, capsys):
    assert main(["looks", "--night", "--out", str(tmp_path)]) == 0
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    pipelines = manifest["pipelines"]
    assert list(pipelines) == ["all", *(f"no_{e}" for e in glare.night.EFFECTS)]
    adapting = pipelines["all"]["adaptation_cd_m2"]
    assert adapting == sorted(adapting, reverse=True)  # entering the dark: falling
    assert len(set(pipelines["no_adaptation"]["adaptation_cd_m2"])) == 1  # adapted at once
    assert pipelines["no_glare"]["pupil_mm"] == [None] * len(adapting)
    frames = {name: read_exr(tmp_path / f"{name}.exr") for name in pipelines}
    for name, frame in frames.items():
        assert frame.shape == (300, 480, 3) and 0.0 <= frame.min() and frame.max() <= 200.0
        if name != "all":  # each effect changes what is shown
            assert np.abs(frame - frames["all"]).max() > 1.0, name
    assert Image.open(tmp_path / "night.png").size == (960, 1280)
    assert "[5/5] no_scotopic" in capsys.readouterr().err


def test_psf_command_writes_a_png_and_exr(tmp_path):
    png, exr = tmp_path / "psf.png", tmp_path / "psf.exr"
    assert (
        main(
            [
                "psf",
                "--model",
                "wave",
                "--pupil-mm",
                "3",
                "--particles",
                "100",
                "--pixel-deg",
                "0.04",
                "--size",
                "61",
                "--out",
                str(png),
                "--exr",
                str(exr),
            ]
        )
        == 0
    )
    image = np.asarray(Image.open(png))
    assert image.shape == (61, 61, 3) and image.max() == 255
    kernel = read_exr(exr)
    assert kernel.shape == (61, 61, 3) and 0.9 < kernel.sum(axis=(0, 1)).min() <= 1.0


def test_psf_command_takes_an_aperture_image(tmp_path):
    bars = np.ones((101, 101), dtype=np.uint8) * 255
    bars[:, 48:53] = 0
    Image.fromarray(bars).save(tmp_path / "bars.png")
    assert (
        main(
            [
                "psf",
                "--model",
                "wave",
                "--pupil-mm",
                "3",
                "--no-eyelashes",
                "--no-eyelid",
                "--particles",
                "0",
                "--aperture-image",
                str(tmp_path / "bars.png"),
                "--aperture-spacing-mm",
                "0.03",
                "--pixel-deg",
                "0.04",
                "--size",
                "41",
                "--luminance",
                "--out",
                str(tmp_path / "bars_psf.png"),
            ]
        )
        == 0
    )
    assert np.asarray(Image.open(tmp_path / "bars_psf.png")).shape == (41, 41)


def test_gallery_command_renders_every_configuration(tmp_path):
    assert main(["gallery", "--out", str(tmp_path), "--pixel-deg", "0.05", "--size", "41"]) == 0
    captions = json.loads((tmp_path / "wave_gallery.json").read_text())
    assert len(captions) == 10
    for name in captions:
        assert Image.open(tmp_path / f"{name}.png").size == (41, 41)
    # Luidolt Fig. 5.6: the pupil series is on one scale, so a larger pupil shows more glare
    glow = []
    for pupil in (2, 4, 6, 8):
        codes = np.asarray(Image.open(tmp_path / f"wave_particles_pupil_{pupil}mm.png"))
        y, x = np.indices(codes.shape[:2]) - 20
        glow.append(codes[np.hypot(x, y) > 3].astype(float).mean())
    assert np.all(np.diff(glow) > 0)


def test_calibrate_fit_writes_a_dated_calibration_with_the_readings_hash(tmp_path):
    readings = tmp_path / "readings.csv"
    # codes 0, 93, ..., 1023 (= 11 × 93)
    rows = ["code,luminance_cd_m2"] + [
        f"{c},{0.3 + 250 * (c / 1023) ** 2.4:.5f}" for c in range(0, 1024, 93)
    ]
    readings.write_text("\n".join(rows) + "\n")
    out = tmp_path / "display.json"
    assert (
        main(
            [
                "calibrate",
                "fit",
                str(readings),
                "--out",
                str(out),
                "--method",
                "gog",
                "--label",
                "test",
            ]
        )
        == 0
    )
    data = json.loads(out.read_text())
    assert data["status"] == "unverified" and len(data["readings_sha256"]) == 64
    assert data["created"] and abs(data["model"]["gamma"] - 2.4) < 0.01


def test_protocol_commands(tmp_path, capsys):
    from pathlib import Path

    root = Path(__file__).parents[1] / "src" / "glarelab" / "protocols"
    assert main(["protocol", "check", str(root / "spencer1995.toml")]) == 0
    assert "valid protocol of the staircase paradigm (study spencer1995)" in (
        capsys.readouterr().out
    )
    assert main(["protocol", "check", "luidolt2020"]) == 0  # a shipped study by its name
    bad = tmp_path / "bad.toml"
    bad.write_text(
        (root / "luidolt2020.toml").read_text().replace("scale_max = 7", "scale_maxx = 7")
    )
    assert main(["protocol", "check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert (
        "questionnaire.scale_maxx: unknown key" in err
        and "questionnaire.scale_max: missing" in err
    )
    capsys.readouterr()
    assert main(["protocol", "keys", "matching"]) == 0
    out = capsys.readouterr().out
    assert "| [[glare.methods]] |  | required | 1-12 tables |" in out
    assert "| glare.methods[].model |  | required | str |" in out
    assert main(["protocol", "keys", "yoshida2008"]) == 0  # a protocol: its paradigm's keys
    assert capsys.readouterr().out == out


def test_an_unclear_no_cache_value_is_refused_before_the_command(tmp_path, capsys, monkeypatch):
    # GLARELAB_NO_CACHE=maybe was taken as 'use the cache' (psf wrote its kernel)
    monkeypatch.setenv("GLARELAB_NO_CACHE", "maybe")
    out = tmp_path / "k.png"
    assert main(["psf", "--out", str(out), "--size", "33", "--model", "gaussian"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "glarelab psf: GLARELAB_NO_CACHE must be 1 (no kernel cache, as --no-cache), 0 or unset "
        "(the cache), got 'maybe'"
    )
    assert list(tmp_path.iterdir()) == []
