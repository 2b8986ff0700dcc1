"""Every option acts or is refused: an option given twice, an option the command would ignore,
an empty path and an output inside a stimulus set end in one line naming the option (exit 2),
with nothing written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from glarelab.cli import main
from glarelab.stimuli.exr import write_exr
from glarelab.stimuli.stimulus_set import build_stimulus_set

ROOT = Path(__file__).parents[2]
READINGS = ROOT / "calibrations" / "example-readings.csv"


def refused(argv, capsys, tmp_path, *named) -> str:
    before = sorted(tmp_path.rglob("*"))
    capsys.readouterr()
    try:
        status = main([str(a) for a in argv])
    except SystemExit as stop:
        status = stop.code
    err = capsys.readouterr().err
    assert status == 2, err
    lines = [line for line in err.strip().splitlines() if not line.startswith("[glarelab]")]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for text in named:
        assert text in lines[0], err
    assert sorted(tmp_path.rglob("*")) == before
    return lines[0]


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["run", "luidolt2020", "--simulate", "--participant", "P1", "--participant", "P2"],
         "--participant is given twice"),
        (["--no-cache", "--no-cache", "protocol", "check", "luidolt2020"],
         "--no-cache is given twice"),
        (["calibrate", "fit", READINGS, "--out", "a.json", "--out", "b.json"],
         "--out is given twice"),
        (["run", "luidolt2020", "--simulate", "--seed", "1", "--seed", "2"],
         "--seed is given twice"),
    ],
)  # fmt: skip
def test_an_option_given_twice_is_refused(argv, named, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    refused(argv, capsys, tmp_path, named)


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--age", "30"], "--age with --simulate"),
        (["--screenshot", "shot.png"], "--screenshot with --simulate"),
        (["--scripted-keys", "keys.txt"], "--scripted-keys with --simulate"),
        (["--fullscreen"], "--fullscreen with --simulate"),
    ],
)
def test_screen_options_with_simulate_are_refused(extra, named, capsys, tmp_path):
    (tmp_path / "keys.txt").write_text("space 1 return\n")
    argv = ["run", "luidolt2020", "--simulate", "--participant", "P1", "--out", tmp_path / "d"]
    refused([*argv, *[tmp_path / e if e.endswith((".png", ".txt")) else e for e in extra]],
            capsys, tmp_path, named)  # fmt: skip


def test_simulation_options_without_simulate_are_refused(capsys, tmp_path):
    argv = ["run", "luidolt2020", "--participant", "P1", "--out", tmp_path / "d", "--seed", "3"]
    refused(argv, capsys, tmp_path, "--seed", "--simulate")


def test_a_stimulus_set_for_a_questionnaire_is_refused(capsys, tmp_path):
    (tmp_path / "set").mkdir()
    argv = ["run", "luidolt2020", "--simulate", "--participant", "P1", "--out", tmp_path / "d"]
    refused([*argv, "--stimuli", tmp_path / "set"], capsys, tmp_path, "--stimuli", "no images")


def test_a_correction_for_a_study_without_an_anova_is_refused(capsys, tmp_path):
    """Attack case m009: the rating study's Wilcoxon tests have no sphericity to correct."""
    argv = ["power", "luidolt2020", "--participants", "4", "--replications", "2",
            "--workers", "0", "--out", tmp_path / "pw", "--correction", "hf"]  # fmt: skip
    refused(argv, capsys, tmp_path, "--correction hf", "no ANOVA")


@pytest.mark.parametrize("study", ["luidolt2020", "yoshida2008"])
def test_a_block_order_for_a_protocol_without_blocks_is_refused(study, capsys, tmp_path):
    """Attack case r020: a questionnaire's or matching study's order is the participant's
    own; only the staircase orders its blocks by --counterbalance."""
    argv = ["run", study, "--simulate", "--participants", "2", "--seed", "1",
            "--counterbalance", "1", "--out", tmp_path / "data"]  # fmt: skip
    refused(argv, capsys, tmp_path, "--counterbalance 1", "no blocks to order")


def test_a_missing_argument_names_what_the_given_ones_were_read_as(capsys, tmp_path):
    """Attack case m041: a file given without the study is read as the study."""
    argv = ["import-psychopy", "/dev/null", "--out", tmp_path / "x"]
    refused(argv, capsys, tmp_path, "required: CSV; read STUDY as '/dev/null'")


def test_unknown_scripted_key_names_are_refused(capsys, tmp_path):
    pytest.importorskip("psychopy")
    (tmp_path / "keys.txt").write_text("space retrun 1 spcae\n")
    argv = ["run", "luidolt2020", "--participant", "P1", "--out", tmp_path / "d"]
    line = refused([*argv, "--scripted-keys", tmp_path / "keys.txt"], capsys, tmp_path,
                   "'retrun', 'spcae'", "not a key name")  # fmt: skip
    assert "'space'" not in line


@pytest.fixture
def scene(tmp_path):
    image = np.full((32, 32), 1.0, dtype=np.float32)
    image[14:18, 14:18] = 1000.0
    write_exr(tmp_path / "in.exr", image)
    return tmp_path / "in.exr"


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--seed", "3"], "--seed without --flare-lines"),
        (["--model", "wave", "--aperture-spacing-mm", "2"],
         "--aperture-spacing-mm without --aperture-image"),
        (["--model", "wave", "--aperture-image", "{scene}"],
         "without --aperture-spacing-mm: give the size of one of the image's pixels"),
        (["--preview-scale", "log"], "--preview-scale log without --preview"),
        (["--preview-scale", "display"], "--preview-scale display without --preview"),
        # given at their defaults to a model that ignores them: were taken
        (["--model", "gaussian", "--regime", "photopic"], "--regime: not an option of"),
        (["--model", "gaussian", "--particles", "1000"], "--particles: not an option of"),
        (["--model", "wave", "--source-x-deg", "10", "--no-eyelashes", "--no-eyelid"],
         "--source-x-deg with --no-eyelashes and --no-eyelid"),
        (["--model", "wave", "--seed", "3", "--no-eyelashes", "--particles", "0"],
         "--seed with --no-eyelashes and --particles 0"),
        # the exact grid's one autocorrelation serves every wavelength: it was 'scaled'
        (["--model", "wave", "--spectral", "reference"], "--spectral reference without --fresnel"),
        (["--l-dmax", "500", "--calibration", "{calibration}"], "above the --calibration's"),
    ],
)  # fmt: skip
def test_render_options_that_would_be_ignored_are_refused(extra, named, scene, capsys, tmp_path):
    shipped = Path(__file__).parents[2] / "calibrations" / "SYNTHETIC-yoshida2008-433cd-10bit.json"
    names = {"{scene}": str(scene), "{calibration}": str(shipped)}
    extra = [names.get(a, a) for a in extra]
    argv = ["render", scene, tmp_path / "out.exr", "--pixel-deg", "0.02", *extra]
    refused(argv, capsys, tmp_path, named)


def test_psf_luminance_with_the_achromatic_gaussian_is_refused(capsys, tmp_path):
    """``psf --model gaussian --luminance`` wrote the same bytes as without it, silently."""
    argv = ["psf", "--out", tmp_path / "k.png", "--model", "gaussian", "--size", "11"]
    refused([*argv, "--luminance"], capsys, tmp_path, "--luminance: not an option of --model "
            "gaussian, which would ignore it")  # fmt: skip
    assert main([str(a) for a in argv]) == 0  # without it, the kernel


def test_hybrid_flare_lines_act_and_their_seed_with_them(scene, tmp_path):
    """``render --model hybrid --flare-lines`` was refused as an option hybrid ignores; the
    hybrid model takes Spencer's flare lines (on its Vos part) and their seed."""
    from glarelab.stimuli.exr import read_exr

    def render(name, *extra):
        argv = ["render", str(scene), str(tmp_path / name), "--pixel-deg", "0.05",
                "--model", "hybrid", "--no-eyelashes", "--particles", "0", *extra]  # fmt: skip
        assert main(argv) == 0
        return read_exr(tmp_path / name)

    plain = render("plain.exr")
    lines = render("lines.exr", "--flare-lines")
    other = render("other.exr", "--flare-lines", "--seed", "7")
    assert np.abs(lines - plain).max() > 1e-6 * plain.max()  # the lines streak the glare
    assert np.abs(other - lines).max() > 1e-6 * plain.max()  # placed by the seed
    argv = ["render", str(scene), str(tmp_path / "lashes.exr"), "--pixel-deg", "0.05",
            "--model", "hybrid", "--seed", "5"]  # fmt: skip
    assert main(argv) == 0  # the lashes' and particles' seed, without flare lines


def test_an_empty_render_output_is_named_as_empty(scene, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # '' would otherwise mean this folder, with in.exr in it
    line = refused(["render", "in.exr", "", "--pixel-deg", "0.02"], capsys, tmp_path,
                   "output '' is empty (an unset shell variable?)")  # fmt: skip
    assert "overwrite" not in line


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--readings", "5"], "--readings without --photometer"),
        (["--settle-s", "0.5"], "--settle-s without --photometer"),
        (["--readings", "3", "--photometer-serial", "X1"],
         "--readings, --photometer-serial without --photometer"),
    ],
)  # fmt: skip
def test_photometer_options_without_a_photometer_are_refused(extra, named, capsys, tmp_path):
    argv = ["check-display", "spencer1995", "--out", tmp_path / "c.json", *extra]
    refused(argv, capsys, tmp_path, named)


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "luidolt2020", "--simulate", "--participant", "P1", "--out", ""],
        ["looks", "--out", " "],
        ["docs", "--out", ""],
    ],
)
def test_an_empty_out_is_refused(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    refused(argv, capsys, tmp_path, "--out is empty")


def test_an_empty_copy_destination_is_refused(capsys, tmp_path, monkeypatch):
    # an unset shell variable: the copy would land in the working folder without a word
    monkeypatch.chdir(tmp_path)
    refused(["protocol", "copy", "spencer1995", ""], capsys, tmp_path, "destination is empty")


@pytest.fixture(scope="module")
def stimulus_set(tmp_path_factory):
    from glarelab.protocols import load_protocol

    folder = tmp_path_factory.mktemp("sets") / "spencer1995"
    build_stimulus_set(load_protocol("spencer1995"), folder, progress=None)
    return folder


@pytest.mark.parametrize(
    "argv",
    [
        ["analyse", "spencer1995", "x.csv", "--out", "{set}/report"],
        ["stimuli", "build", "yoshida2008", "--out", "{set}/inner"],
        ["looks", "--out", "{set}/looks"],
        ["docs", "--out", "{set}/docs"],
        ["bench", "--out", "{set}/bench"],
        ["demo", "--out", "{set}/demo"],
        ["protocol", "copy", "spencer1995", "{set}"],
        ["protocol", "copy", "spencer1995", "{set}/mine.toml"],
        # into the set's own folder: written there, and the set then failed verification
        ["docs", "--out", "{set}"],
        ["gallery", "--out", "{set}", "--size", "5"],
        ["looks", "--out", "{set}"],
        ["examples", "{set}"],
        ["calibrate", "export-monitor", "calibrations/SYNTHETIC-spencer1995-50cd-8bit.json",
         "--monitor", "lab", "--monitor-folder", "{set}"],
    ],
)  # fmt: skip
def test_no_output_inside_a_stimulus_set(argv, stimulus_set, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("{set}", str(stimulus_set)).replace("calibrations/", f"{ROOT}/calibrations/")
            for a in argv]  # fmt: skip
    before = sorted(stimulus_set.rglob("*"))
    refused(argv, capsys, tmp_path, "inside the stimulus set")
    assert sorted(stimulus_set.rglob("*")) == before


def test_a_protocol_copy_never_replaces_a_link(capsys, tmp_path, monkeypatch):
    # a dangling link's target does not exist, yet the link is someone's: it was replaced
    monkeypatch.chdir(tmp_path)
    (tmp_path / "p.toml").symlink_to(tmp_path / "elsewhere.toml")
    refused(["protocol", "copy", "spencer1995", "p.toml"], capsys, tmp_path, "symbolic link")
    assert (tmp_path / "p.toml").is_symlink()


def test_a_measurement_without_verification_points_is_refused_before_it_starts(capsys, tmp_path):
    argv = ["calibrate", "measure", "--out", tmp_path / "c.json", "--simulate", "300", "0.1",
            "2.2", "--verify-points", "0"]  # fmt: skip
    refused(argv, capsys, tmp_path, "--verify-points", "0")


@pytest.mark.parametrize("text", ["0.0_2", "1_0", " 0.5", "0.5 ", "0x10", "１"])
def test_a_number_option_is_read_as_a_number_is_written(text):
    """``float`` reads Python's 0.0_2 as 0.02 and pads of spaces away: a typo taken as a
    pixel size (as the readings files already refuse ``12_8``)."""
    import argparse

    from glarelab.commands.common import count, number

    with pytest.raises(argparse.ArgumentTypeError, match="is not a"):
        number(0.0, 100.0)(text)
    with pytest.raises(argparse.ArgumentTypeError, match="is not a"):
        count(0)(text.replace(".", ""))


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["sweep", "yoshida2008", "--set", "disk.diameter_deg=0.3,0.4", "--seed", "3"],
         "--seed without --simulate"),
        (["stimuli", "build", "yoshida2008", "--accept-mismatch", "calibration"],
         "--accept-mismatch calibration without --calibration"),
        (["calibrate", "measure", "--simulate", "100", "0.1", "2.2", "--settle-s", "0.5"],
         "--settle-s with --simulate"),
        (["calibrate", "measure", "--simulate", "100", "0.1", "2.2", "--photometer-serial",
          "ABC"], "--photometer-serial with --simulate"),
        (["power", "yoshida2008", "--participants", "6", "8", "6"],
         "--participants 6 8 6: 6 given more than once"),
    ],
)  # fmt: skip
def test_an_option_its_mode_ignores_is_refused(argv, named, capsys, tmp_path):
    """Each ran and ignored the option (the simulated photometer's settling time, a seed for
    a sweep that simulates no one, a mismatch accepted of no calibration)."""
    out = {"sweep": "s", "stimuli": "set", "calibrate": "c.json", "power": "p"}[argv[0]]
    refused([*argv, "--out", tmp_path / out], capsys, tmp_path, named)


def test_a_vos_pupil_acts_where_there_is_a_halo_and_is_refused_where_there_is_none(
    capsys, tmp_path, monkeypatch
):
    """--pupil-mm was refused for the vos model, whose pupil under 3 mm drops the halo."""
    monkeypatch.chdir(tmp_path)
    image = np.full((101, 101), 1.0)  # 5° across: the halo's ring at 2-4° inside the kernel
    image[50, 50] = 1e6
    write_exr("in.exr", image)
    base = ["--pixel-deg", "0.05", "--model", "vos", "--regime", "mesopic"]
    assert main(["render", "in.exr", "with.exr", *base]) == 0
    assert main(["render", "in.exr", "small.exr", *base, "--pupil-mm", "2.5"]) == 0
    from glarelab.stimuli.exr import read_exr

    assert not np.array_equal(read_exr("with.exr"), read_exr("small.exr"))  # the halo dropped
    refused(["render", "in.exr", "out.exr", "--pixel-deg", "0.05", "--model", "vos",
             "--pupil-mm", "2.5"], capsys, tmp_path, "--pupil-mm with --model vos --regime "
            "photopic")  # fmt: skip


def test_a_models_refusal_names_the_options_given(scene, capsys, tmp_path):
    """The model refused 'wavelength_nm=500.0', a name the command line does not have."""
    argv = ["render", scene, tmp_path / "out.exr", "--pixel-deg", "0.05", "--model", "vos",
            "--regime", "mesopic", "--pupil-mm", "2", "--wavelength-nm", "500"]  # fmt: skip
    line = refused(argv, capsys, tmp_path, "--wavelength-nm 500.0: it shapes only the halo")
    assert "wavelength_nm=" not in line


def test_a_render_edited_since_it_was_written_is_not_overwritten_without_force(
    scene, capsys, tmp_path
):
    """A one-file render replaced a render the user had edited since, and a render into a
    folder refused one even with --force."""
    from glarelab.stimuli.exr import write_exr

    out = tmp_path / "out.exr"
    argv = ["render", str(scene), str(out), "--pixel-deg", "0.05"]
    assert main(argv) == 0 and main(argv) == 0  # its own render, unedited: written again
    write_exr(out, np.full((32, 32), 7.0, dtype=np.float32))  # retouched by the user
    refused(argv, capsys, tmp_path, "out.exr was edited since glarelab wrote it")
    assert main([*argv, "--force"]) == 0
    folder = tmp_path / "many"
    batch = ["render", str(scene), str(scene.with_name("in2.exr")), str(folder),
             "--pixel-deg", "0.05"]  # fmt: skip
    scene.with_name("in2.exr").write_bytes(scene.read_bytes())
    assert main(batch) == 0
    write_exr(folder / "in.exr", np.full((32, 32), 7.0, dtype=np.float32))
    refused(batch, capsys, tmp_path, "in.exr was edited since glarelab wrote it")
    assert main([*batch, "--force"]) == 0


def test_a_kernel_psf_wrote_and_the_user_edited_is_not_overwritten(scene, capsys, tmp_path):
    """``psf --exr`` recorded no content of its files, so a render over one the user had
    edited since replaced it without --force."""
    exr = tmp_path / "kernel.exr"
    assert main(["psf", "--out", str(tmp_path / "k.png"), "--exr", str(exr), "--model",
                 "gaussian", "--size", "31"]) == 0  # fmt: skip
    exr.write_text("the user's own data\n")
    argv = ["render", str(scene), str(exr), "--pixel-deg", "0.05"]
    refused(argv, capsys, tmp_path, "kernel.exr was edited since glarelab wrote it")
    assert exr.read_text() == "the user's own data\n"
