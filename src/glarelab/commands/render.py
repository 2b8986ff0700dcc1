"""The ``glarelab`` commands of rendering glare: render, psf, gallery, looks."""

from __future__ import annotations

import argparse
import json
import re
import time
from pathlib import Path

import numpy as np

from glarelab import glare
from glarelab.display.calibration import Calibration
from glarelab.files.atomic import atomic_path, write_text
from glarelab.files.folders import record_written
from glarelab.files.inputs import input_file
from glarelab.glare._validation import check_image
from glarelab.glare.models.wave import MAX_PARTICLES
from glarelab.glare.rendering.renderer import RENDER_BYTES_PER_PIXEL
from glarelab.stimuli.apertures import load_aperture_image
from glarelab.stimuli.exr import read_exr, write_exr
from glarelab.stimuli.preview import preview_png, psf_figure, psf_png
from glarelab.stimuli.shapes import disk

from .common import (
    FORCE_HELP,
    check_memory,
    claim_output,
    count,
    folder_to_write,
    number,
    output_file,
    writes_into,
    writing_into,
)
from .common import log as _log

DEFAULT_L_DMAX_CD_M2 = 220.0  # --l-dmax without a calibration: Yoshida 2008 §3's display
# a kernel's digitisation: about 110 bytes per pixel, plus the wave model's pupil spectra
PSF_BYTES_PER_PIXEL = 128
PSF_FIXED_BYTES = 0.5 * 2**30


# the options each model takes; one given to a model that ignores it is refused
MODEL_OPTIONS = {
    "gaussian": {"sigma_deg"},
    "vos": {"regime", "age", "flare_lines", "seed", "wavelength_nm", "pupil_mm"},
    "wave": {
        "pupil_mm", "no_eyelashes", "no_eyelid", "particles", "fresnel", "spectral", "seed",
        "source_x_deg", "diaphragm_sides", "cross_screen", "aperture_image",
        "aperture_spacing_mm",
    },
}  # fmt: skip
MODEL_OPTIONS["hybrid"] = MODEL_OPTIONS["wave"] | {"regime", "age", "flare_lines"}


def _check_options(args: argparse.Namespace) -> None:
    """Refuse an option the chosen model would ignore (``--pupil-mm`` with the Gaussian)."""
    defaults = argparse.ArgumentParser()
    _add_model_options(defaults)
    default = vars(defaults.parse_args([]))
    every = set().union(*MODEL_OPTIONS.values())
    given = {n for n in default if getattr(args, n, default[n]) != default[n]}
    given |= set(getattr(args, "given_options", set())) & set(default)  # at a default too
    ignored = sorted(name for name in every - MODEL_OPTIONS[args.model] if name in given)
    if ignored:
        shown = ", ".join("--" + name.replace("_", "-") for name in ignored)
        raise ValueError(f"{shown}: not an option of --model {args.model}, which would ignore it")
    if args.model == "vos" and "pupil_mm" in given and args.regime == "photopic":
        raise ValueError(
            "--pupil-mm with --model vos --regime photopic: the pupil drops the lenticular "
            "halo when under 3 mm (Spencer §2.1), and the photopic PSF has none, so it would "
            "be ignored; give --regime mesopic or scotopic"
        )
    reference = getattr(args, "spectral", "scaled") == "reference"
    if args.model in ("wave", "hybrid") and reference and not getattr(args, "fresnel", False):
        raise ValueError(
            "--spectral reference without --fresnel: each wavelength's PSF is integrated from "
            "one autocorrelation of the aperture, as --spectral scaled does, so it would be "
            "ignored; give --fresnel (a Fresnel term per wavelength) or leave --spectral scaled"
        )
    if args.model == "vos" and "seed" in given and "flare_lines" not in given:
        raise ValueError(
            "--seed without --flare-lines: the seed places Spencer's flare lines, and the vos "
            "model without them would ignore it"
        )
    if "aperture_spacing_mm" in given and "aperture_image" not in given:
        raise ValueError(
            "--aperture-spacing-mm without --aperture-image: the spacing scales the obstacle "
            "image, so without one it would be ignored"
        )
    if args.model in ("wave", "hybrid") and "source_x_deg" in given:
        if getattr(args, "no_eyelashes", False) and getattr(args, "no_eyelid", False):
            raise ValueError(
                "--source-x-deg with --no-eyelashes and --no-eyelid: the source's direction "
                "moves the lashes and the lid across the pupil, so without them it would be "
                "ignored"
            )
    if args.model in ("wave", "hybrid") and "seed" in given:
        flare_lines = args.model == "hybrid" and getattr(args, "flare_lines", False)
        if (
            getattr(args, "no_eyelashes", False)
            and getattr(args, "particles", 1) == 0
            and not flare_lines
        ):
            raise ValueError(
                "--seed with --no-eyelashes and --particles 0: the seed draws the lashes and "
                "the particles (and, with --model hybrid, places the flare lines), so without "
                "them it would be ignored"
            )
    if "aperture_image" in given and "aperture_spacing_mm" not in given:
        raise ValueError(
            f"--aperture-image {args.aperture_image} without --aperture-spacing-mm: give the "
            "size of one of the image's pixels on the pupil, mm (a number > 0)"
        )


def build_model(args: argparse.Namespace) -> glare.GlareModel:
    """The glare model named by the command-line options.

    Parameters
    ----------
    args
        The parsed options: ``model`` and the model's own (``sigma_deg``, ``regime``,
        ``pupil_mm``, ...).

    Returns
    -------
    glarelab.glare.GlareModel
        The model.

    Raises
    ------
    ValueError
        For an unknown model, or an option that is not the model's.
    """
    if args.model not in MODEL_OPTIONS:
        raise ValueError(f"--model must be one of {MODEL_CHOICES}; got {args.model!r}")
    _check_options(args)
    try:
        return _made_model(args)
    except ValueError as error:  # the model's words, with its keys named as the options
        text = str(error)
        for name in sorted(set().union(*MODEL_OPTIONS.values()), key=len, reverse=True):
            text = re.sub(rf"\b{name}=", f"--{name.replace('_', '-')} ", text)
        raise ValueError(text) from None


def _made_model(args: argparse.Namespace) -> glare.GlareModel:
    """:func:`build_model`'s model, once its options are checked."""
    if args.model == "gaussian":
        return glare.GaussianGlare(sigma_deg=args.sigma_deg)
    if args.model == "vos":
        return glare.VosGlare(
            regime=args.regime,
            age=args.age,
            flare_lines=args.flare_lines,
            seed=args.seed,
            wavelength_nm=args.wavelength_nm,
            pupil_mm=args.pupil_mm,
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
            # the seed draws the lashes and particles; without them it is the flare lines'
            # alone (hybrid), which the wave part would refuse as a seed without effect
            seed=args.seed if (not args.no_eyelashes or args.particles) else 0,
            source_x_deg=args.source_x_deg,
            diaphragm_sides=args.diaphragm_sides,
            cross_screen=args.cross_screen,
            obstacle_image=image,
            obstacle_spacing_mm=args.aperture_spacing_mm,
        )
        if args.model == "wave":
            return wave
        return glare.HybridGlare(
            wave=wave,
            regime=args.regime,
            age=args.age,
            flare_lines=args.flare_lines,
            seed=args.seed if args.flare_lines else 0,  # it places the flare lines alone
        )
    raise ValueError(f"--model must be one of {MODEL_CHOICES}; got {args.model!r}")


MODEL_CHOICES = ("gaussian", "vos", "wave", "hybrid")
MIN_PIXEL_DEG = 1e-5  # 0.04 arcsec, far below the eye's resolution; smaller is a typo


def _add_model_options(parser: argparse.ArgumentParser, default: str = "vos") -> None:
    group = parser.add_argument_group("glare model")
    group.add_argument("--model", choices=MODEL_CHOICES, default=default)
    group.add_argument(
        "--sigma-deg", type=number(MIN_PIXEL_DEG, 90), default=0.34, help="Gaussian σ (deg)"
    )
    group.add_argument("--regime", choices=glare.vos.REGIMES, default="photopic")
    group.add_argument(
        "--age", type=number(0, 120), default=None, help="observer age, years (eq. 10)"
    )
    group.add_argument(
        "--flare-lines", action="store_true", help="add Spencer's flare lines (vos, hybrid)"
    )
    group.add_argument(
        "--seed",
        type=count(0),
        default=0,
        help="seed of the flare lines (vos, hybrid), the eyelashes and the particles (wave)",
    )
    group.add_argument(
        "--wavelength-nm",
        type=number(0, above=True),
        default=None,
        help="monochromatic halo (default: white)",
    )
    wave = parser.add_argument_group("wave optics (--model wave|hybrid)")
    wave.add_argument(
        "--pupil-mm",
        type=number(0, above=True),
        default=None,
        help="pupil, mm (wave, hybrid: default from the field luminance, Moon-Spencer; vos: "
        "under 3 mm the halo is dropped, mesopic and scotopic only)",
    )
    wave.add_argument("--no-eyelashes", action="store_true")
    wave.add_argument("--no-eyelid", action="store_true")
    wave.add_argument("--particles", type=count(0, MAX_PARTICLES), default=1000)
    wave.add_argument("--fresnel", action="store_true", help="Luidolt eq. 5.6 Fresnel term")
    wave.add_argument(
        "--spectral", choices=glare.wave.SPECTRAL_METHODS, default="scaled",
        help="reference (one Fresnel term per wavelength) only with --fresnel",
    )  # fmt: skip
    wave.add_argument("--source-x-deg", type=number(-60, 60), default=0.0)
    wave.add_argument("--diaphragm-sides", type=count(3, 360), default=None)
    wave.add_argument("--cross-screen", choices=("4-point", "trigonal"), default=None)
    wave.add_argument("--aperture-image", type=Path, default=None, help="obstacle PNG/EXR")
    wave.add_argument("--aperture-spacing-mm", type=number(0, above=True), default=None)


def _short(model: glare.GlareModel) -> str:
    """A model's name and the parameters that differ from its defaults (its repr is long)."""
    import dataclasses

    if not dataclasses.is_dataclass(model):
        return type(model).__name__
    changed = []
    for item in dataclasses.fields(model):
        value = getattr(model, item.name)
        default = item.default if item.default is not dataclasses.MISSING else None
        simple = isinstance(value, int | float | str | bool | None)
        if item.repr and simple and value != default:
            changed.append(f"{item.name}={value!r}")
    text = f"{type(model).__name__}({', '.join(changed)})"
    return text if len(text) <= 120 else text[:117] + "..."


def odd_size(text: str) -> int:
    """An argparse type: a kernel's odd size in pixels (its centre is a pixel).

    Parameters
    ----------
    text
        The option's text.

    Returns
    -------
    int
        An odd size, 3-16385 pixels.

    Raises
    ------
    argparse.ArgumentTypeError
        For anything else.
    """
    size = count(3, 16385)(text)
    if size % 2 == 0:
        raise argparse.ArgumentTypeError(f"{size} must be odd, so the kernel has a centre pixel")
    return size


def _render(args: argparse.Namespace) -> int:
    *inputs, output = args.paths
    if not inputs:
        raise ValueError("render needs an input EXR and an output EXR (or folder)")
    for i, text in enumerate(args.paths):
        if not text.strip():
            role = "output" if i == len(args.paths) - 1 else "input"
            raise ValueError(
                f"{role} {text!r} is empty (an unset shell variable?): give a path; an empty "
                "one would mean the working folder"
            )
    if args.preview_scale is not None and args.preview is None:
        raise ValueError(
            f"--preview-scale {args.preview_scale} without --preview: it scales the PNG "
            "preview, so without one it would be ignored"
        )
    for source in inputs:  # a folder, a FIFO, /dev/null: named as what they are
        if not Path(source).exists() and not Path(source).is_symlink():
            raise FileNotFoundError(f"input {source}: no such file")
        input_file(source, what="input")
    folder = len(inputs) > 1 or output.endswith(("/", "\\")) or Path(output).is_dir()
    if folder and len(inputs) > 1 and Path(output).suffix.lower() == ".exr":
        if not Path(output).is_dir():  # a file's name: a folder called out.exr was made
            raise ValueError(
                f"{len(inputs)} inputs and the output {output}, a file's name: several inputs "
                "are written into a folder (give a folder, e.g. with_glare/)"
            )
    if folder:  # many files: one renderer per image shape, its kernel made once
        if args.preview:
            raise ValueError("--preview is for one output file; render that file on its own")
        names = [Path(name).name for name in inputs]
        if len(set(names)) < len(names):
            raise ValueError(
                "inputs of the same file name would write the same output: "
                f"{sorted({n for n in names if names.count(n) > 1})}"
            )
        folder_to_write(Path(output), names)
        for source in inputs:  # every input read and checked before any output is made
            try:
                check_image("luminance", read_exr(source), channels=(3,))
            except ValueError as error:
                raise ValueError(f"input {source}: {error}; nothing was rendered") from None
        # a refusal from here on (the model's options, the calibration, an image the
        # renderer refuses) leaves the folder as it was: no claim of a file never written
        with writing_into(Path(output), names, "render", force=args.force):
            targets = [Path(output) / name for name in names]
            return _render_images(args, inputs, targets, folder=True)
    return _render_images(args, inputs, [Path(output)], folder=False)


def _render_images(
    args: argparse.Namespace, inputs: list[str], targets: list[Path], *, folder: bool
) -> int:
    """Render each input into its target: one file, or (``folder``) the files of a folder
    :func:`_render` claimed them in."""
    sources = [*inputs, args.aperture_image, args.calibration]
    for target in targets:
        output_file(target, (".exr",), "rendered image", inputs=sources, force=args.force,
                    shared=folder)  # fmt: skip
    if args.preview:
        output_file(args.preview, (".png",), "preview", inputs=[*sources, *targets],
                    force=args.force)  # fmt: skip
    model = build_model(args)  # reads the aperture image: after the outputs are checked
    display = Calibration.load(args.calibration) if args.calibration else None
    if args.l_dmax is None:
        args.l_dmax = display.max_cd_m2 if display is not None else DEFAULT_L_DMAX_CD_M2
    elif display is not None and args.l_dmax > display.max_cd_m2 * (1.0 + 1e-9):
        raise ValueError(
            f"--l-dmax {args.l_dmax:g} is above the --calibration's white "
            f"({display.max_cd_m2:g} cd/m²): the display cannot show it; leave --l-dmax out "
            "to use the white"
        )
    renderers: dict[tuple, glare.GlareRenderer] = {}
    for index, (source, target) in enumerate(zip(inputs, targets, strict=True), start=1):
        _log(f"[{index}/{len(inputs)}] reading {source}")
        image = read_exr(source)
        channels = 1 if image.ndim == 2 else image.shape[2]
        check_memory(
            RENDER_BYTES_PER_PIXEL[channels] * image.shape[0] * image.shape[1],
            f"rendering {source} ({image.shape[1]} × {image.shape[0]} px)",
        )
        _log(
            f"{image.shape} image, max {float(image.max()):.4g} cd/m²; rendering with "
            f"{_short(model)}"
        )
        start = time.perf_counter()
        key = image.shape[:2]
        if key not in renderers:
            renderers[key] = glare.GlareRenderer(
                model,
                pixel_deg=args.pixel_deg,
                shape=key,
                l_dmax_cd_m2=args.l_dmax,
                composition=args.composition,
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
            how = (  # the whole kernel, but float32 transforms round
                "exact"
                if result.error_bound_codes == 0
                else f"the whole kernel; error bound {result.error_bound_codes:.3g} codes"
            )
            _log(
                f"done in {seconds:.2f} s ({how}); energy outside the kernel "
                f"{np.max(result.kernel.energy_outside):.3g}, outside the image "
                f"{float(np.max(left)):.3g} of the excess"
            )
        else:
            _log(f"done in {seconds:.2f} s; error bound {result.error_bound_codes:.3g} codes")
        if not folder:
            claim_output(target, "render")
        write_exr(target, result.image.astype(np.float32))
        if not folder:
            record_written(target.parent, [target.name])  # an edit later is then named
        _log(f"wrote {target}")
        if args.preview:
            claim_output(args.preview, "render --preview")
            preview_png(
                args.preview,
                result.image,
                l_dmax_cd_m2=args.l_dmax,
                scale=args.preview_scale or "display",
            )
            record_written(Path(args.preview).parent, [Path(args.preview).name])
            _log(f"wrote {args.preview}")
    if folder:
        record_written(targets[0].parent, [target.name for target in targets])
    return 0


def _psf(args: argparse.Namespace) -> int:
    if args.luminance and args.model == "gaussian":
        raise ValueError(
            "--luminance: not an option of --model gaussian, which would ignore it (the "
            "Gaussian is achromatic: its kernel is a luminance kernel either way)"
        )
    sources = [args.aperture_image]
    output_file(args.out, (".png",), "kernel image", inputs=sources, force=args.force)
    # the kernel as a figure: axes in degrees and the intensity scale, PNG and PDF
    figure_png = Path(args.out).with_name(f"{Path(args.out).stem}_axes.png")
    for path in (figure_png, figure_png.with_suffix(".pdf")):
        output_file(path, (path.suffix,), "kernel figure", inputs=sources, force=args.force)
    if args.exr is not None:
        output_file(args.exr, (".exr",), "kernel", inputs=[*sources, args.out], force=args.force)
    model = build_model(args)  # reads the aperture image: after the outputs are checked
    shape = (args.size, args.size)
    check_memory(
        PSF_FIXED_BYTES + PSF_BYTES_PER_PIXEL * (1 if args.luminance else 3) * args.size**2,
        f"a {args.size}² kernel",
    )
    _log(f"computing the {args.size}² kernel of {type(model).__name__} at {args.pixel_deg}°/px")
    start = time.perf_counter()
    kernel = glare.digitise_kernel(model, args.pixel_deg, shape, colour=not args.luminance)
    _log(
        f"done in {time.perf_counter() - start:.2f} s; energy outside the kernel "
        f"{np.max(kernel.energy_outside):.3g}"
    )
    claim_output(args.out, "psf")
    psf_png(args.out, kernel.values)
    for path in (figure_png, figure_png.with_suffix(".pdf")):
        claim_output(path, "psf")
    psf_figure(
        figure_png,
        kernel.values,
        pixel_deg=args.pixel_deg,
        title=f"{type(model).__name__} kernel, {args.size}² px at {args.pixel_deg:g}°/px",
    )
    written = [args.out, figure_png, figure_png.with_suffix(".pdf")]
    if args.exr is not None:
        claim_output(args.exr, "psf --exr")
        write_exr(args.exr, kernel.values.astype(np.float32))
        written.append(args.exr)
    for path in written:  # their content recorded: an edit later is then named, not overwritten
        record_written(Path(path).parent, [Path(path).name])
        print(Path(path).resolve())
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
    for pupil in (2, 4, 6, 8):  # Luidolt's kernel grows with the pupil: one scale for all four
        models[f"wave_particles_pupil_{pupil}mm"] = (
            f"pupil {pupil} mm and 1000 particles, Luidolt's convention (energy ∝ pupil area; "
            "one scale for the series, his Fig. 5.6)",
            glare.WaveOpticsGlare(
                pupil_mm=float(pupil), eyelashes=False, eyelid=False,
                pupil_convention="Luidolt2020",
            ),
        )  # fmt: skip
    return models


GALLERY_SERIES = "wave_particles_pupil_"  # kernels shown on one scale, that of the brightest


def _gallery(args: argparse.Namespace) -> int:
    models = gallery_models()
    figures = [f"{n}_axes{end}" for n in models for end in (".png", ".pdf")]
    written = [f"{n}.png" for n in models] + figures + ["wave_gallery.json"]
    check_memory(  # before the folder is made: a refusal leaves nothing behind
        PSF_FIXED_BYTES + PSF_BYTES_PER_PIXEL * 3 * args.size**2, f"a {args.size}² kernel"
    )
    out = writes_into(Path(args.out), written, "gallery")
    captions = {}
    series = {}
    for index, (name, (caption, model)) in enumerate(models.items(), start=1):
        _log(f"[{index}/{len(models)}] {caption}")
        start = time.perf_counter()
        kernel = glare.digitise_kernel(model, args.pixel_deg, (args.size, args.size), colour=True)
        captions[name] = {"caption": caption, "seconds": round(time.perf_counter() - start, 2)}
        if name.startswith(GALLERY_SERIES):
            series[name] = kernel.values
            continue
        psf_png(out / f"{name}.png", kernel.values)
        psf_figure(out / f"{name}_axes.png", kernel.values, pixel_deg=args.pixel_deg,
                   title=caption)  # fmt: skip
        _log(f"    {captions[name]['seconds']} s → {out / name}.png, {name}_axes.png")
    peak = max((float(v.max()) for v in series.values()), default=None)
    for name, values in series.items():
        psf_png(out / f"{name}.png", values, peak=peak)
        psf_figure(out / f"{name}_axes.png", values, pixel_deg=args.pixel_deg, peak=peak,
                   title=captions[name]["caption"])  # fmt: skip
        _log(f"    {captions[name]['seconds']} s → {out / name}.png (the series' scale)")
    write_text(out / "wave_gallery.json", json.dumps(captions, indent=2))
    record_written(out, written)  # a file edited since is then not overwritten unsaid
    print(out.resolve())
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


NIGHT_LOOKS = {  # the street of the night2026 protocol at three quarters of its size
    "size_px": (480, 300),
    "pixel_deg": 0.05,
    "lamps": 3,
    "lamp_cd_m2": 1e4,
    "ambient_cd_m2": 0.05,
    "start_cd_m2": 100.0,
    "seconds": 2.0,  # adapted by then; adaptation is shown at its first frame after 0.5 s
    "adapting_s": 0.5,
    "frame_rate_hz": 4.0,
    "display_max_cd_m2": 200.0,
    "adapted_display_cd_m2": 3.0,
}


def _looks_night(args: argparse.Namespace) -> int:
    """The night street with each effect of the pipeline on and off, side by side."""
    from matplotlib.figure import Figure

    from glarelab.stimuli.night import night_sequence, night_street
    from glarelab.stimuli.preview import to_display

    effects = glare.night.EFFECTS
    pipelines = {"all": effects} | {
        f"no_{e}": tuple(x for x in effects if x != e) for e in effects
    }
    names = [f"{n}{end}" for n in pipelines for end in (".exr", ".png")]
    written = [*names, "night.png", "manifest.json"]
    out = writes_into(Path(args.out), written, "looks --night")
    spec = NIGHT_LOOKS
    street = night_street(
        spec["size_px"], pixel_deg=spec["pixel_deg"], lamps=spec["lamps"],
        lamp_cd_m2=spec["lamp_cd_m2"], ambient_cd_m2=spec["ambient_cd_m2"],
        rng=np.random.default_rng(0),
    )  # fmt: skip
    shown = night_sequence(
        street, "enter_dark", seconds=spec["seconds"], frame_rate_hz=spec["frame_rate_hz"],
        start_cd_m2=spec["start_cd_m2"],
    )  # fmt: skip
    l_dmax = spec["display_max_cd_m2"]
    adapting = max(round(spec["adapting_s"] / shown["frame_time_s"]) - 1, 0)
    frames, manifest = {}, {"scene": {k: v for k, v in spec.items()}, "pipelines": {}}
    for index, (name, chosen) in enumerate(pipelines.items(), start=1):
        _log(f"[{index}/{len(pipelines)}] {name}: {', '.join(chosen)}")
        start = time.perf_counter()
        adapted = (  # the adaptation's options only where it runs (else refused as unused)
            {
                "frame_time_s": shown["frame_time_s"],
                "initial_adaptation_cd_m2": shown["initial_adaptation_cd_m2"],
            }
            if "adaptation" in chosen
            else {}
        )
        night = glare.render_night(
            shown["frames"], pixel_deg=spec["pixel_deg"], effects=chosen,
            display_max_cd_m2=l_dmax, adapted_display_cd_m2=spec["adapted_display_cd_m2"],
            **adapted,
        )  # fmt: skip
        # the adaptation's pair while the eye adapts, the others once it has
        at = adapting if name in ("all", "no_adaptation") else len(night.frames) - 1
        frames[name] = night.frames[-1]
        frames[name, "adapting"] = night.frames[adapting]
        write_exr(out / f"{name}.exr", night.frames[-1].astype(np.float32))
        preview_png(out / f"{name}.png", night.frames[at], l_dmax_cd_m2=l_dmax)
        manifest["pipelines"][name] = {
            "effects": list(chosen),
            "seconds": round(time.perf_counter() - start, 3),
            "adaptation_cd_m2": night.adaptation_cd_m2.tolist(),
            "pupil_mm": [None if np.isnan(p) else float(p) for p in night.pupil_mm],
        }
    figure = Figure(figsize=(9.6, 3.2 * len(effects)), dpi=100)
    axes = figure.subplots(len(effects), 2)
    for row, effect in enumerate(effects):
        when = (
            f"{spec['adapting_s']:g} s after leaving {spec['start_cd_m2']:g} cd/m²"
            if effect == "adaptation"
            else f"after {spec['seconds']:g} s"
        )
        for column, (name, title) in enumerate(
            ((f"no_{effect}", f"without {effect}"), ("all", "all effects"))
        ):
            axis = axes[row, column]
            image = frames[name, "adapting"] if effect == "adaptation" else frames[name]
            axis.imshow(to_display(image, l_dmax_cd_m2=l_dmax), interpolation="none")
            axis.set_title(f"{title}, {when}", fontsize=9)
            axis.set_axis_off()
    figure.suptitle(
        f"A night street entered from {spec['start_cd_m2']:g} cd/m² (lamps "
        f"{spec['lamp_cd_m2']:g} cd/m², display {l_dmax:g} cd/m²): each effect off and on",
        fontsize=10,
    )
    figure.tight_layout()
    with atomic_path(out / "night.png") as temporary:
        figure.savefig(temporary, format="png", metadata={"Software": None})
    write_text(out / "manifest.json", json.dumps(manifest, indent=2, default=str))
    record_written(out, written)
    _log(f"wrote {out / 'night.png'} and {out / 'manifest.json'}")
    print(out.resolve())
    return 0


def _looks(args: argparse.Namespace) -> int:
    if args.night:
        return _looks_night(args)
    from matplotlib.figure import Figure

    names = [f"{n}{end}" for n in DEMO_MODELS for end in (".exr", ".png", "_log.png")]
    written = ["stimulus.exr", *names, "profiles.png", "manifest.json"]
    out = writes_into(Path(args.out), written, "looks")
    stimulus = disk(**DEMO_DISK)
    write_exr(out / "stimulus.exr", stimulus["img"].astype(np.float32))
    pixel_deg = stimulus["pixel_deg"]
    n = stimulus["img"].shape[0]
    offsets = (np.arange(n) - n // 2) * pixel_deg
    figure = Figure(figsize=(7, 4.5), dpi=120)
    axis = figure.subplots()
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
    with atomic_path(out / "profiles.png") as temporary:
        figure.savefig(temporary, format="png")
    write_text(out / "manifest.json", json.dumps(manifest, indent=2, default=str))
    record_written(out, written)
    _log(f"wrote {out / 'profiles.png'} and {out / 'manifest.json'}")
    print(out.resolve())
    return 0


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
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
    render.add_argument(
        "--pixel-deg",
        type=number(MIN_PIXEL_DEG, 10),
        required=True,
        help="visual angle of a pixel, degrees (0-10)",
    )
    render.add_argument(
        "--l-dmax",
        type=number(0, 1e9, above=True),
        default=None,
        help="display maximum, cd/m²; default the --calibration's white, else 220",
    )
    render.add_argument(
        "--composition",
        "--method",  # its former name
        dest="composition",
        choices=("Yoshida2008", "Spencer1995"),
        default="Yoshida2008",
        help="how the spread glare is put back: Yoshida2008 (clamped) or Spencer1995 (added)",
    )
    render.add_argument("--precision", choices=("float64", "float32"), default="float64")
    render.add_argument(
        "--tolerance-codes",
        type=number(0),
        default=0.5,
        help="largest error allowed, display codes (default 0.5; 0 = exact, full kernel)",
    )
    render.add_argument(
        "--calibration", type=Path, help="display calibration the error is counted on"
    )
    render.add_argument("--explain", action="store_true", help="print the plan and its bound")
    render.add_argument("--preview", type=Path, help="also write a PNG preview here")
    render.add_argument(
        "--preview-scale",
        choices=("display", "log"),
        default=None,
        help="the preview's tone scale (default display; with --preview)",
    )
    render.add_argument("--force", action="store_true", help=FORCE_HELP)
    _add_model_options(render)
    render.set_defaults(run=_render)

    psf = commands.add_parser("psf", help="render a glare model's kernel as a PNG")
    psf.add_argument("--out", type=Path, required=True, help="PNG (Kakimoto's tone curve)")
    psf.add_argument("--exr", type=Path, default=None, help="also write the kernel as EXR")
    psf.add_argument(
        "--pixel-deg", type=number(MIN_PIXEL_DEG, 10), default=0.01, help="degrees per pixel"
    )
    psf.add_argument(
        "--size", type=odd_size, default=401, help="kernel size in pixels (odd, 3-16385)"
    )
    psf.add_argument(
        "--luminance",
        action="store_true",
        help="luminance only, no colour (not with --model gaussian, achromatic either way)",
    )
    psf.add_argument("--force", action="store_true", help=FORCE_HELP)
    _add_model_options(psf, default="wave")
    psf.set_defaults(run=_psf)

    gallery = commands.add_parser("gallery", help="render the wave-optics PSF gallery")
    gallery.add_argument("--out", type=Path, default=Path("docs/gallery"))
    gallery.add_argument(
        "--pixel-deg", type=number(MIN_PIXEL_DEG, 10), default=0.01, help="degrees per pixel"
    )
    gallery.add_argument(
        "--size", type=odd_size, default=201, help="kernel size in pixels (odd, 3-16385)"
    )
    gallery.set_defaults(run=_gallery)

    looks = commands.add_parser("looks", help="render a glare stimulus with each model")
    looks.add_argument("--out", type=Path, default=Path("out/looks"), help="output folder")
    looks.add_argument(
        "--night",
        action="store_true",
        help="instead: a night street through the night-vision pipeline, each effect off and "
        "on side by side (night.png)",
    )
    looks.set_defaults(run=_looks)
