"""The ``glarelab`` command."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import glare
from protocols import PARADIGMS, ProtocolError, describe_schema, load_protocol
from stimuli.apertures import load_aperture_image
from stimuli.calibration import Calibration, fit_calibration, read_readings
from stimuli.exr import read_exr, write_exr
from stimuli.preview import preview_png, psf_png
from stimuli.shapes import disk
from stimuli.stimulus_set import build_stimulus_set, verify_stimulus_set

__all__ = ["build_model", "main"]

PROTOCOL_HELP = "a shipped study's name (yoshida2008, spencer1995, luidolt2020, …) or a TOML file"


def _log(message: str) -> None:
    print(f"[glarelab] {message}", file=sys.stderr, flush=True)


def build_model(args: argparse.Namespace) -> glare.GlareModel:
    """The glare model named by the command-line options."""
    if args.model == "gaussian":
        return glare.GaussianGlare(sigma_deg=args.sigma_deg)
    if args.model == "vos":
        return glare.VosGlare(
            regime=args.regime,
            age=args.age,
            flare_lines=args.flare_lines,
            seed=args.seed,
            wavelength_nm=args.wavelength_nm,
        )
    if args.model in ("wave", "hybrid"):
        image = None
        if args.aperture_image is not None:
            image = load_aperture_image(args.aperture_image)
        wave = glare.WaveOpticsGlare(
            pupil_mm=args.pupil_mm,
            eyelashes=not args.no_eyelashes,
            eyelid=not args.no_eyelid,
            particles=args.particles,
            fresnel=args.fresnel,
            spectral=args.spectral,
            seed=args.seed,
            source_x_deg=args.source_x_deg,
            diaphragm_sides=args.diaphragm_sides,
            cross_screen=args.cross_screen,
            obstacle_image=image,
            obstacle_spacing_mm=args.aperture_spacing_mm,
        )
        if args.model == "wave":
            return wave
        return glare.HybridGlare(wave=wave, regime=args.regime, age=args.age)
    raise ValueError(f"--model must be one of {MODEL_CHOICES}; got {args.model!r}")


MODEL_CHOICES = ("gaussian", "vos", "wave", "hybrid")


def _add_model_options(parser: argparse.ArgumentParser, default: str = "vos") -> None:
    group = parser.add_argument_group("glare model")
    group.add_argument("--model", choices=MODEL_CHOICES, default=default)
    group.add_argument("--sigma-deg", type=float, default=0.34, help="Gaussian σ (deg)")
    group.add_argument("--regime", choices=glare.vos.REGIMES, default="photopic")
    group.add_argument("--age", type=float, default=None, help="observer age, years (eq. 10)")
    group.add_argument("--flare-lines", action="store_true", help="add Spencer's flare lines")
    group.add_argument("--seed", type=int, default=0, help="seed of the flare lines")
    group.add_argument(
        "--wavelength-nm", type=float, default=None, help="monochromatic halo (default: white)"
    )
    wave = parser.add_argument_group("wave optics (--model wave|hybrid)")
    wave.add_argument("--pupil-mm", type=float, default=None, help="default: Moon-Spencer")
    wave.add_argument("--no-eyelashes", action="store_true")
    wave.add_argument("--no-eyelid", action="store_true")
    wave.add_argument("--particles", type=int, default=1000)
    wave.add_argument("--fresnel", action="store_true", help="Luidolt eq. 5.6 Fresnel term")
    wave.add_argument("--spectral", choices=glare.wave.SPECTRAL_METHODS, default="scaled")
    wave.add_argument("--source-x-deg", type=float, default=0.0)
    wave.add_argument("--diaphragm-sides", type=int, default=None)
    wave.add_argument("--cross-screen", choices=("4-point", "trigonal"), default=None)
    wave.add_argument("--aperture-image", type=Path, default=None, help="obstacle PNG/EXR")
    wave.add_argument("--aperture-spacing-mm", type=float, default=None)


def _render(args: argparse.Namespace) -> int:
    model = build_model(args)
    *inputs, output = args.paths
    if not inputs:
        raise ValueError("render needs an input EXR and an output EXR (or folder)")
    targets = [Path(output)]
    folder = len(inputs) > 1 or output.endswith(("/", "\\")) or Path(output).is_dir()
    if folder:  # many files: one renderer per image shape, its kernel made once
        Path(output).mkdir(parents=True, exist_ok=True)
        targets = [Path(output) / Path(name).name for name in inputs]
        if args.preview:
            raise ValueError("--preview is for one output file; render that file on its own")
    display = Calibration.load(args.calibration) if args.calibration else None
    renderers: dict[tuple, glare.GlareRenderer] = {}
    for number, (source, target) in enumerate(zip(inputs, targets, strict=True), start=1):
        _log(f"[{number}/{len(inputs)}] reading {source}")
        image = read_exr(source)
        _log(f"{image.shape} image, max {float(image.max()):.4g} cd/m²; rendering with {model}")
        start = time.perf_counter()
        key = image.shape[:2]
        if key not in renderers:
            renderers[key] = glare.GlareRenderer(
                model,
                pixel_deg=args.pixel_deg,
                shape=key,
                l_dmax_cd_m2=args.l_dmax,
                method=args.method,
                precision=args.precision,
                tolerance_codes=args.tolerance_codes,
                display=display,
                log=_log,
            )
        result = renderers[key].render(image)
        if args.explain:
            print(result.plan)
            print(
                f"  result: error bound {result.error_bound_codes:.3g} display codes"
                + (f" ({result.fallback})" if result.fallback else "")
            )
        seconds = time.perf_counter() - start
        if result.plan.exact and result.energy_outside_image is not None:
            left = result.energy_outside_image / np.maximum(result.excess_energy, 1e-300)
            _log(
                f"done in {seconds:.2f} s (exact); energy outside the kernel "
                f"{np.max(result.kernel.energy_outside):.3g}, outside the image "
                f"{float(np.max(left)):.3g} of the excess"
            )
        else:
            _log(f"done in {seconds:.2f} s; error bound {result.error_bound_codes:.3g} codes")
        write_exr(target, result.image.astype(np.float32))
        _log(f"wrote {target}")
        if args.preview:
            preview_png(
                args.preview, result.image, l_dmax_cd_m2=args.l_dmax, scale=args.preview_scale
            )
            _log(f"wrote {args.preview}")
    return 0


# name: (label, model, colour); colour renders a white RGB disk so the halo shows its colours
DEMO_MODELS = {
    "gaussian": ("Gaussian, σ = 0.34° (Yoshida 2008)", glare.GaussianGlare(), False),
    "vos_photopic": ("Vos PSF, photopic (Spencer 1995 eq. 5)", glare.VosGlare(), False),
    "vos_mesopic": (
        "Vos PSF, mesopic with lenticular halo (Spencer 1995 eq. 8)",
        glare.VosGlare(regime="mesopic"),
        True,
    ),
    "vos_scotopic_flare": (
        "Vos PSF, scotopic with flare lines (Spencer 1995 eq. 9, §3.2)",
        glare.VosGlare(regime="scotopic", flare_lines=True, seed=1),
        True,
    ),
}
REC709_LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # ITU-R BT.709 luminance of linear RGB
DEMO_DISK = {  # Yoshida 2008 §3: a 0.3° disk; level "E" = 4000 cd/m²
    "field_deg": 8.0,
    "pixel_deg": 0.0125,
    "disk_diameter_deg": 0.3,
    "disk_cd_m2": 4000.0,
    "background_cd_m2": 1.0,
}


def _looks(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stimulus = disk(**DEMO_DISK)
    write_exr(out / "stimulus.exr", stimulus["img"].astype(np.float32))
    pixel_deg = stimulus["pixel_deg"]
    n = stimulus["img"].shape[0]
    offsets = (np.arange(n) - n // 2) * pixel_deg
    figure, axis = plt.subplots(figsize=(7, 4.5), dpi=120)
    manifest = {"stimulus": {k: v for k, v in stimulus.items() if k not in ("img", "mask")}}
    for index, (name, (label, model, colour)) in enumerate(DEMO_MODELS.items(), start=1):
        _log(f"[{index}/{len(DEMO_MODELS)}] {label}")
        image = np.repeat(stimulus["img"][..., None], 3, axis=2) if colour else stimulus["img"]
        start = time.perf_counter()
        result = glare.render_glare(image, model, pixel_deg=pixel_deg, l_dmax_cd_m2=220.0)
        seconds = time.perf_counter() - start
        luminance = result.image if not colour else result.image @ REC709_LUMINANCE
        write_exr(out / f"{name}.exr", result.image.astype(np.float32))
        preview_png(out / f"{name}.png", result.image, l_dmax_cd_m2=220.0)
        preview_png(out / f"{name}_log.png", result.image, l_dmax_cd_m2=220.0, scale="log")
        axis.semilogy(offsets[n // 2 :], luminance[n // 2, n // 2 :], label=label)
        manifest[name] = {
            "label": label,
            "seconds": round(seconds, 3),
            "energy_outside_kernel": float(np.max(result.kernel.energy_outside)),
            "parameters": result.parameters,
        }
        _log(f"    {seconds:.2f} s → {out / name}.exr, .png, _log.png")
    axis.axhline(220.0, color="grey", lw=0.8, ls="--", label="L_dmax = 220 cd/m²")
    axis.set(
        xlabel="angle from the disk centre (deg)",
        ylabel="luminance (cd/m²)",
        title="0.3° disk at 4000 cd/m² on 1 cd/m²: glare by model",
    )
    axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(out / "profiles.png")
    plt.close(figure)
    (out / "manifest.json").write_text(json.dumps(manifest, indent=2, default=str))
    _log(f"wrote {out / 'profiles.png'} and {out / 'manifest.json'}")
    print(out.resolve())
    return 0


def _psf(args: argparse.Namespace) -> int:
    model = build_model(args)
    shape = (args.size, args.size)
    _log(f"computing the {args.size}² kernel of {type(model).__name__} at {args.pixel_deg}°/px")
    start = time.perf_counter()
    kernel = glare.digitise_kernel(model, args.pixel_deg, shape, colour=not args.luminance)
    _log(
        f"done in {time.perf_counter() - start:.2f} s; energy outside the kernel "
        f"{np.max(kernel.energy_outside):.3g}"
    )
    psf_png(args.out, kernel.values)
    _log(f"wrote {args.out}")
    if args.exr is not None:
        write_exr(args.exr, kernel.values.astype(np.float32))
        _log(f"wrote {args.exr}")
    return 0


# Kakimoto 2004 Fig. 5 and Luidolt 2020 Fig. 5.6: name → (caption, model)
def gallery_models() -> dict[str, tuple[str, glare.GlareModel]]:
    """The configurations of the wave-optics gallery."""
    camera = {"eyelashes": False, "eyelid": False, "particles": 0}
    models = {
        "wave_eyelashes_eyelid": (
            "eyelashes and eyelid, 5 mm pupil",
            glare.WaveOpticsGlare(pupil_mm=5.0, particles=0),
        ),
        "wave_daylight_pupil": (
            "small daylight pupil (1000 cd/m², Moon-Spencer)",
            glare.WaveOpticsGlare(field_luminance_cd_m2=1000.0, particles=0),
        ),
        "wave_night_pupil": (
            "large night pupil (0.01 cd/m², Moon-Spencer)",
            glare.WaveOpticsGlare(field_luminance_cd_m2=0.01, particles=0),
        ),
        "wave_cross_screen_round": (
            "4-point cross screen, round 6 mm diaphragm",
            glare.WaveOpticsGlare(pupil_mm=6.0, cross_screen="4-point", **camera),
        ),
        "wave_cross_screen_trigonal": (
            "trigonal cross screen, round 6 mm diaphragm",
            glare.WaveOpticsGlare(pupil_mm=6.0, cross_screen="trigonal", **camera),
        ),
        "wave_hexagonal_diaphragm": (
            "hexagonal 6 mm diaphragm",
            glare.WaveOpticsGlare(pupil_mm=6.0, diaphragm_sides=6, **camera),
        ),
    }
    for pupil in (2, 4, 6, 8):
        models[f"wave_particles_pupil_{pupil}mm"] = (
            f"pupil {pupil} mm and 1000 particles (Luidolt Fig. 5.6)",
            glare.WaveOpticsGlare(pupil_mm=float(pupil), eyelashes=False, eyelid=False),
        )
    return models


def _gallery(args: argparse.Namespace) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    models = gallery_models()
    captions = {}
    for index, (name, (caption, model)) in enumerate(models.items(), start=1):
        _log(f"[{index}/{len(models)}] {caption}")
        start = time.perf_counter()
        kernel = model.kernel(args.pixel_deg, (args.size, args.size), colour=True)
        psf_png(out / f"{name}.png", kernel.values)
        captions[name] = {"caption": caption, "seconds": round(time.perf_counter() - start, 2)}
        _log(f"    {captions[name]['seconds']} s → {out / name}.png")
    (out / "wave_gallery.json").write_text(json.dumps(captions, indent=2))
    return 0


def _stimuli_build(args: argparse.Namespace) -> int:
    protocol = load_protocol(args.protocol)
    calibration = Calibration.load(args.calibration) if args.calibration else None
    _log(f"building the {protocol.study} stimulus set into {args.out}")
    start = time.perf_counter()
    manifest = build_stimulus_set(protocol, args.out, calibration=calibration)
    clipped = sum(
        r.get("encoding", {}).get("above_max", 0) + r.get("encoding", {}).get("below_black", 0)
        for r in manifest["images"].values()
    )
    _log(
        f"{len(manifest['files'])} files in {time.perf_counter() - start:.1f} s; calibration "
        f"status '{manifest['calibration']['status']}'; {clipped} pixels clipped by the display"
    )
    print(Path(args.out).resolve())
    return 0


def _stimuli_verify(args: argparse.Namespace) -> int:
    problems = verify_stimulus_set(args.folder)
    if problems:
        for problem in problems:
            print(f"{args.folder}: {problem}", file=sys.stderr)
        return 1
    print(f"{args.folder}: every file matches its manifest")
    return 0


def _protocol_keys(args: argparse.Namespace) -> int:
    print("| key | unit | default | allowed | meaning |\n| --- | --- | --- | --- | --- |")
    paradigm = args.paradigm
    if paradigm not in PARADIGMS:  # a protocol: its paradigm
        paradigm = load_protocol(paradigm).paradigm
    for row in describe_schema(paradigm):
        print("| " + " | ".join(row) + " |")
    return 0


def _protocol_check(args: argparse.Namespace) -> int:
    from experiments.paradigms import PARADIGMS as RUNS

    protocol = load_protocol(args.protocol)
    RUNS[protocol.paradigm].observer.check(protocol)  # the simulated observers' parameters
    print(
        f"{args.protocol}: valid protocol of the {protocol.paradigm} paradigm (study "
        f"{protocol.study}), sha256 {protocol.sha256}"
    )
    return 0


def _calibrate_fit(args: argparse.Namespace) -> int:
    readings = read_readings(args.readings)
    calibration = fit_calibration(
        readings,
        bit_depth=args.bit_depth,
        method=args.method,
        label=args.label,
        source=str(args.readings),
    )
    calibration.save(args.out)
    _log(
        f"{len(readings)} readings → {args.method} calibration, {calibration.black_cd_m2:.4g}-"
        f"{calibration.max_cd_m2:.4g} cd/m², status '{calibration.status}' → {args.out}"
    )
    if calibration.model:
        _log(
            f"gain-offset-gamma residuals: RMS {calibration.model['rms_residual_cd_m2']:.3g} cd/m²"
        )
    return 0


def _calibrate_measure(args: argparse.Namespace) -> int:
    from stimuli.measure import MeasurementSession
    from stimuli.measure_psychopy import run_measurement

    session = MeasurementSession(
        bit_depth=args.bit_depth,
        out=args.out,
        rng=np.random.default_rng(args.seed),
        points=args.points,
        order=args.order,
        verify_points=args.verify_points,
        tolerance_fraction=args.tolerance,
        label=args.label,
    )
    photometer = None
    if args.simulate is not None:  # a display following L = black + (white - black) x^gamma
        white, black, gamma = args.simulate
        top = 2**args.bit_depth - 1

        def photometer(code: int) -> float:
            return black + (white - black) * (code / top) ** gamma

    result = run_measurement(
        session,
        photometer=photometer,
        fullscr=not args.windowed,
        allow_fewer_bits=args.allow_fewer_bits,
        log=_log,
    )
    for flag in result["flags"]:
        _log(f"flag: {flag}")
    _log(f"calibration status: {result['status']}; session saved at {session.session_path}")
    return 0 if result["status"] == "passed" else 1


VISION = ("none", "glasses", "lenses", "other")


def _age(text: str) -> int:
    """An age in whole years, 0-120."""
    try:
        age = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"age must be whole years; got {text!r}") from None
    if not 0 <= age <= 120:
        raise argparse.ArgumentTypeError(f"age must be 0-120 years; got {age}")
    return age


def _detail(text: str) -> str | None:
    """A participant detail: trimmed text, or none when empty."""
    return text.strip() or None


def _experiment_info(args: argparse.Namespace) -> None:
    """Ask for the participant's details in a dialog, as PsychoPy's experiment info does."""
    import os

    from stimuli.psychopy_window import qt_dialog_available

    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        raise ValueError("--participant is required (no display for the participant dialog)")
    if not qt_dialog_available():
        raise ValueError(
            "--participant is required: the participant dialog needs Qt's X11 libraries "
            "(Debian: libxcb-cursor0)"
        )
    from psychopy import gui

    info = {
        "participant": "",
        "session": args.session,
        "age": "" if args.age is None else args.age,
        "sex": ["", "f", "m", "x"],
        "vision": list(VISION),
    }
    dialog = gui.DlgFromDict(info, title=f"glarelab {args.title}", order=list(info))
    if not dialog.OK:
        raise ValueError("the participant dialog was cancelled: nothing was run or written")
    args.participant = str(info["participant"]).strip()
    try:
        args.session = int(info["session"])
        args.age = _age(str(info["age"])) if str(info["age"]).strip() else None
    except (ValueError, argparse.ArgumentTypeError) as error:
        raise ValueError(
            f"the dialog's session {info['session']!r} must be a whole number and its age "
            f"0-120 years ({error})"
        ) from None
    args.sex = info["sex"] or None
    args.vision = info["vision"] or None


def _run(args: argparse.Namespace) -> int:
    from experiments.session import SimulatedFrontend, run_session

    protocol = load_protocol(args.protocol or args.study)
    args.title = protocol.study
    out = Path(args.out)
    if args.simulate:
        from experiments.session import make_observer, shows_images
        from stimuli.stimulus_set import cached_stimulus_set

        ids = (
            [args.participant]
            if args.participant
            else [f"sim{index:02d}" for index in range(1, args.participants + 1)]
        )
        stimuli = args.stimuli
        if stimuli is None and shows_images(protocol):
            _log(f"building (or reusing) the {protocol.study} stimulus set the observers look at")
            stimuli = cached_stimulus_set(protocol)
            _log(f"stimulus set: {stimuli}")
        for number, participant in enumerate(ids, start=1):
            observer = make_observer(protocol, participant, seed=args.seed, stimuli=stimuli)
            frontend = SimulatedFrontend(observer, trial_delay_s=args.trial_delay_ms / 1000)
            sidecar = run_session(
                protocol,
                participant,
                out=out,
                frontend=frontend,
                session=args.session,
                stimuli=stimuli,
                resume=args.resume,
                counterbalance=args.counterbalance,
                simulated=True,
                participant_info={"simulated_observer_seed": args.seed},
            )
            done = f"{sidecar['trials']} trials, {sidecar['status']}"
            _log(f"[{number}/{len(ids)}] {participant}: {done}")
        print(out.resolve())
        return 0
    if args.participant is None:
        _experiment_info(args)
    from experiments.psychopy_frontend import PsychoPyFrontend

    calibration = Calibration.load(args.calibration) if args.calibration else None
    scripted = Path(args.scripted_keys).read_text().split() if args.scripted_keys else None
    frontend = PsychoPyFrontend(
        protocol,
        stimuli=args.stimuli,
        calibration=calibration,
        fullscreen=args.fullscreen,
        scripted_keys=scripted,
        screenshot=args.screenshot,
    )
    sidecar = run_session(
        protocol,
        args.participant,
        out=out,
        frontend=frontend,
        session=args.session,
        stimuli=args.stimuli,
        calibration=calibration,
        allow_uncalibrated=args.allow_uncalibrated,
        resume=args.resume,
        counterbalance=args.counterbalance,
        participant_info={"age": args.age, "sex": args.sex, "vision_correction": args.vision},
        accept_mismatch=tuple(args.accept_mismatch or ()),
        allow_unmeasured_refresh=args.allow_unmeasured_refresh,
    )
    run = sidecar["runs"][-1]
    _log(
        f"{args.participant}: {sidecar['trials']} trials, {sidecar['status']}"
        + (f" ({run['ended_by']})" if run.get("ended_by") else "")
        + f"; data in {out.resolve()}"
    )
    return 0 if sidecar["status"] == "completed" else 3


def _check_display(args: argparse.Namespace) -> int:
    from experiments.check_display import check_display, write_check

    protocol = load_protocol(args.protocol)
    calibration = Calibration.load(args.calibration) if args.calibration else None
    if args.out is not None:
        out = args.out
    elif args.calibration is not None:
        out = args.calibration.with_suffix(".display-check.json")
    else:
        raise ValueError("give --out FILE, or --calibration (the check is written next to it)")
    result = check_display(
        protocol,
        stimuli=args.stimuli,
        calibration=calibration,
        frames=args.frames,
        fullscreen=not args.windowed,
        log=_log,
    )
    empty = result["frame_intervals_empty"]
    print(
        f"screen {result['resolution_px'][0]} × {result['resolution_px'][1]} px, refresh "
        f"{result['refresh_hz_measured'] or float('nan'):.2f} Hz measured, frame intervals "
        f"{empty['median_ms']:.2f} ± {empty['sd_ms']:.2f} ms (worst {empty['max_ms']:.1f} ms, "
        f"{100 * empty['late_fraction']:.1f} % late), {result['bits_per_channel']} bits per "
        f"channel ({result['framebuffer_levels']} of {result['framebuffer_levels_asked']} "
        "levels distinct in the frame buffer)"
    )
    for check in result["checks"]:
        print(
            f"  {'ok  ' if check['passed'] else 'FAIL'} {check['name']}: protocol "
            f"{check['expected']}, display {check['actual']}"
        )
    if "flash" in result:
        flash = result["flash"]
        print(
            f"flash frame: draw {flash['draw_median_ms']:.2f} ms (99th percentile "
            f"{flash['draw_p99_ms']:.2f}), {100 * flash['draw_fraction_of_frame']:.1f} % of a "
            f"{flash['frame_period_ms']:.2f} ms frame; flip to flip "
            f"{flash['frame_intervals_drawing']['median_ms']:.2f} ms"
        )
    _log(f"wrote {write_check(result, out)}")
    return 0 if all(c["passed"] for c in result["checks"]) else 1


def _analyse(args: argparse.Namespace) -> int:
    from analysis.report import write_report

    protocol = load_protocol(args.protocol or args.study)
    report = write_report(
        protocol,
        args.csv,
        args.out,
        exclude_incomplete=args.exclude_incomplete,
        stimuli=args.stimuli,
    )
    _log(f"wrote {report} with its tables and figures")
    print(report.resolve())
    return 0


def _demo(args: argparse.Namespace) -> int:
    from glarelab.demo import run_demo

    report = run_demo(
        args.protocol, args.out, participants=args.participants, seed=args.seed, log=_log
    )
    print(f"report: {report.resolve()}")
    return 0


def _docs(args: argparse.Namespace) -> int:
    from glarelab.docs import data_reference, protocol_reference

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "protocols.md").write_text(protocol_reference())
    (out / "data.md").write_text(data_reference())
    _log(f"wrote {out / 'protocols.md'} and {out / 'data.md'}")
    return 0


def _bench(args: argparse.Namespace) -> int:
    from glarelab.bench import run_bench

    run_bench(
        args.out,
        large=args.large,
        only=tuple(args.only) if args.only else None,
        spectral=not args.no_spectral,
        repeats=args.repeats,
        log=_log,
    )
    _log(f"wrote {args.out / 'bench.csv'}, bench.md and the Pareto plots")
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glarelab", description="Glare illusion psychophysics suite"
    )
    commands = parser.add_subparsers(dest="command", required=True)

    render = commands.add_parser(
        "render", help="add glare to linear float EXR images (one kernel for many files)"
    )
    render.add_argument(
        "paths",
        nargs="+",
        metavar="INPUT... OUTPUT",
        help="linear luminance EXRs (Y or RGB), cd/m², then the output EXR (float32), or an "
        "output folder (several inputs, or a name ending in /) for files of the same names",
    )
    render.add_argument("--pixel-deg", type=float, required=True, help="visual angle of a pixel")
    render.add_argument("--l-dmax", type=float, default=220.0, help="display maximum, cd/m²")
    render.add_argument("--method", choices=("Yoshida2008", "Spencer1995"), default="Yoshida2008")
    render.add_argument("--precision", choices=("float64", "float32"), default="float64")
    render.add_argument(
        "--tolerance-codes",
        type=float,
        default=0.5,
        help="largest error allowed, display codes (default 0.5; 0 = exact, full kernel)",
    )
    render.add_argument(
        "--calibration", type=Path, help="display calibration the error is counted on"
    )
    render.add_argument("--explain", action="store_true", help="print the plan and its bound")
    render.add_argument("--preview", type=Path, help="also write a PNG preview here")
    render.add_argument("--preview-scale", choices=("display", "log"), default="display")
    _add_model_options(render)
    render.set_defaults(run=_render)

    psf = commands.add_parser("psf", help="render a glare model's kernel as a PNG")
    psf.add_argument("--out", type=Path, required=True, help="PNG (Kakimoto's tone curve)")
    psf.add_argument("--exr", type=Path, default=None, help="also write the kernel as EXR")
    psf.add_argument("--pixel-deg", type=float, default=0.01)
    psf.add_argument("--size", type=int, default=401, help="kernel size in pixels (odd)")
    psf.add_argument("--luminance", action="store_true", help="luminance only, no colour")
    _add_model_options(psf, default="wave")
    psf.set_defaults(run=_psf)

    stimuli = commands.add_parser("stimuli", help="build or verify a study's stimulus set")
    stimuli_commands = stimuli.add_subparsers(dest="stimuli_command", required=True)
    build = stimuli_commands.add_parser("build", help="build a stimulus set from a protocol")
    build.add_argument("protocol", help=PROTOCOL_HELP)
    build.add_argument("--out", type=Path, required=True)
    build.add_argument("--calibration", type=Path, default=None, help="display calibration JSON")
    build.set_defaults(run=_stimuli_build)
    verify = stimuli_commands.add_parser("verify", help="re-hash a stimulus set")
    verify.add_argument("folder", type=Path)
    verify.set_defaults(run=_stimuli_verify)

    protocol = commands.add_parser("protocol", help="check a protocol or list its keys")
    protocol_commands = protocol.add_subparsers(dest="protocol_command", required=True)
    check = protocol_commands.add_parser("check", help="validate a protocol file")
    check.add_argument("protocol", help=PROTOCOL_HELP)
    check.set_defaults(run=_protocol_check)
    keys = protocol_commands.add_parser("keys", help="every key of a study's protocol")
    keys.add_argument(
        "paradigm", help=f"a paradigm ({', '.join(PARADIGMS)}) or a protocol ({PROTOCOL_HELP})"
    )
    keys.set_defaults(run=_protocol_keys)

    calibrate = commands.add_parser("calibrate", help="display calibration")
    calibrate_commands = calibrate.add_subparsers(dest="calibrate_command", required=True)
    fit = calibrate_commands.add_parser("fit", help="fit a calibration to photometer readings")
    fit.add_argument("readings", type=Path, help="CSV with columns code, luminance_cd_m2")
    fit.add_argument("--out", type=Path, required=True)
    fit.add_argument("--bit-depth", type=int, default=10, choices=(8, 10, 12, 16))
    fit.add_argument("--method", choices=("pchip", "gog"), default="pchip")
    fit.add_argument("--label", default="", help="display, photometer, operator")
    fit.set_defaults(run=_calibrate_fit)

    measure = calibrate_commands.add_parser(
        "measure", help="measure a display with a photometer (PsychoPy, full-field patches)"
    )
    measure.add_argument("--out", type=Path, required=True, help="calibration JSON to write")
    measure.add_argument("--bit-depth", type=int, default=10, choices=(8, 10, 12, 16))
    measure.add_argument("--points", type=int, default=33)
    measure.add_argument("--order", choices=("random", "reversed"), default="random")
    measure.add_argument("--verify-points", type=int, default=5)
    measure.add_argument("--tolerance", type=float, default=0.03, help="relative, for 'passed'")
    measure.add_argument("--seed", type=int, default=0)
    measure.add_argument("--label", default="")
    measure.add_argument("--windowed", action="store_true")
    measure.add_argument(
        "--allow-fewer-bits",
        action="store_true",
        help="measure although the window gives fewer bits per channel than --bit-depth",
    )
    measure.add_argument(
        "--simulate",
        type=float,
        nargs=3,
        metavar=("WHITE", "BLACK", "GAMMA"),
        default=None,
        help="a simulated photometer instead of typed readings (dry runs)",
    )
    measure.set_defaults(run=_calibrate_measure)

    run = commands.add_parser("run", help="run a study session (PsychoPy) or simulated sessions")
    run.add_argument("study", help=f"the protocol: {PROTOCOL_HELP}")
    run.add_argument(
        "--participant",
        default=None,
        help="participant id (file-name safe); without it, a dialog asks for the details",
    )
    run.add_argument("--session", type=int, default=1, help="session number (default 1)")
    run.add_argument(
        "--protocol", type=Path, default=None, help="a protocol TOML file (instead of STUDY)"
    )
    run.add_argument("--stimuli", type=Path, default=None, help="the stimulus set folder")
    run.add_argument("--calibration", type=Path, default=None, help="display calibration JSON")
    run.add_argument(
        "--allow-uncalibrated",
        action="store_true",
        help="run without a valid calibration (recorded)",
    )
    run.add_argument(
        "--accept-mismatch",
        nargs="+",
        choices=("resolution", "refresh", "bit-depth", "calibration"),
        metavar="CHECK",
        help="run although the display differs from the protocol in these checks (recorded): "
        "resolution, refresh, bit-depth, calibration",
    )
    run.add_argument(
        "--allow-unmeasured-refresh",
        action="store_true",
        help="run although the refresh rate could not be measured (recorded; flips are then "
        "paced by the clock at the protocol's rate)",
    )
    run.add_argument(
        "--out",
        type=Path,
        default=Path("data"),
        help="folder for the session files (default data)",
    )
    run.add_argument("--resume", action="store_true", help="continue an interrupted session")
    run.add_argument("--fullscreen", action="store_true")
    run.add_argument(
        "--counterbalance", type=int, choices=(0, 1), default=None, help="Spencer block order"
    )
    run.add_argument("--age", type=_age, default=None, help="participant's age, years (0-120)")
    run.add_argument(
        "--sex", type=_detail, default=None, help="participant's sex (as the lab records it)"
    )
    run.add_argument(
        "--vision",
        choices=VISION,
        default=None,
        help=f"vision correction: {', '.join(VISION)}",
    )
    run.add_argument(
        "--scripted-keys",
        type=Path,
        default=None,
        help="dry run: a text file of PsychoPy key names separated by spaces or lines, one per "
        "press (e.g. 'space up up return y n y'); Escape when they run out",
    )
    run.add_argument("--screenshot", type=Path, default=None, help="save the first trial's screen")
    run.add_argument("--simulate", action="store_true", help="simulated observers, no screen")
    run.add_argument(
        "--participants", type=int, default=10, help="simulated participants (default 10)"
    )
    run.add_argument(
        "--seed", type=int, default=0, help="seed of the simulated observers (default 0)"
    )
    run.add_argument("--trial-delay-ms", type=float, default=0.0, help=argparse.SUPPRESS)
    run.set_defaults(run=_run)

    check = commands.add_parser(
        "check-display",
        help="measure the display: resolution, refresh, frame jitter, bits, a flash's cost",
    )
    check.add_argument("protocol", help="a shipped protocol's name or a protocol TOML file")
    check.add_argument("--stimuli", type=Path, default=None, help="also time a flash of this set")
    check.add_argument("--calibration", type=Path, default=None, help="the display calibration")
    check.add_argument(
        "--out", type=Path, default=None, help="JSON to write (default: next to --calibration)"
    )
    check.add_argument(
        "--frames", type=int, default=600, help="flips per measurement (default 600)"
    )
    check.add_argument("--windowed", action="store_true", help="a window, not full screen")
    check.set_defaults(run=_check_display)

    analyse = commands.add_parser("analyse", help="analyse session CSVs: tables, figures, report")
    analyse.add_argument("study", help=f"the protocol: {PROTOCOL_HELP}")
    analyse.add_argument("csv", nargs="+", type=Path, help="session CSV files")
    analyse.add_argument("--out", type=Path, required=True, help="report folder")
    analyse.add_argument(
        "--protocol", type=Path, default=None, help="a protocol TOML file (instead of STUDY)"
    )
    analyse.add_argument("--stimuli", type=Path, default=None, help="the set, for provenance")
    analyse.add_argument(
        "--exclude-incomplete",
        action="store_true",
        help="drop participants with a missing design cell (listed in the report)",
    )
    analyse.set_defaults(run=_analyse)

    bench = commands.add_parser(
        "bench", help="time each speed knob against its error in display codes"
    )
    bench.add_argument("--out", type=Path, default=Path("out/bench"))
    bench.add_argument("--large", action="store_true", help="add the 4096² scenes")
    bench.add_argument("--only", nargs="+", metavar="WORKLOAD", help="run only these workloads")
    bench.add_argument(
        "--no-spectral", action="store_true", help="skip the wave-optics spectral section"
    )
    bench.add_argument("--repeats", type=int, default=3)
    bench.set_defaults(run=_bench)

    docs = commands.add_parser("docs", help="regenerate docs/protocols.md and docs/data.md")
    docs.add_argument("--out", type=Path, default=Path("docs"))
    docs.set_defaults(run=_docs)

    gallery = commands.add_parser("gallery", help="render the wave-optics PSF gallery")
    gallery.add_argument("--out", type=Path, default=Path("docs/gallery"))
    gallery.add_argument("--pixel-deg", type=float, default=0.01)
    gallery.add_argument("--size", type=int, default=401)
    gallery.set_defaults(run=_gallery)

    looks = commands.add_parser("looks", help="render a glare stimulus with each model")
    looks.add_argument("--out", type=Path, default=Path("out/looks"), help="output folder")
    looks.set_defaults(run=_looks)

    demo = commands.add_parser(
        "demo", help="the whole study on simulated observers: stimuli, sessions, analysis, report"
    )
    demo.add_argument(
        "--protocol", default="yoshida2008", help=f"{PROTOCOL_HELP} (default yoshida2008)"
    )
    demo.add_argument(
        "--out", type=Path, default=Path("out/demo"), help="output folder (replaced)"
    )
    demo.add_argument("--participants", type=int, default=10)
    demo.add_argument("--seed", type=int, default=1, help="seed of the simulated observers")
    demo.set_defaults(run=_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``glarelab`` command; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    from experiments.loop import SessionAborted

    try:
        return args.run(args)
    except (ValueError, FileNotFoundError, ProtocolError) as error:
        parser.error(f"{args.command}: {error}")
    except (SessionAborted, KeyboardInterrupt) as stop:
        why = stop.args[0] if stop.args else "SIGINT"
        _log(f"{args.command}: stopped by {why} before the first trial; nothing was recorded")
        return 3
    return 2


if __name__ == "__main__":
    sys.exit(main())
