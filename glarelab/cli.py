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
from stimuli.exr import read_exr, write_exr
from stimuli.preview import preview_png
from stimuli.shapes import disk

__all__ = ["build_model", "main"]


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
    raise ValueError(f"--model must be one of 'gaussian', 'vos'; got {args.model!r}")


def _add_model_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("glare model")
    group.add_argument("--model", choices=("gaussian", "vos"), default="vos")
    group.add_argument("--sigma-deg", type=float, default=0.34, help="Gaussian σ (deg)")
    group.add_argument("--regime", choices=glare.vos.REGIMES, default="photopic")
    group.add_argument("--age", type=float, default=None, help="observer age, years (eq. 10)")
    group.add_argument("--flare-lines", action="store_true", help="add Spencer's flare lines")
    group.add_argument("--seed", type=int, default=0, help="seed of the flare lines")
    group.add_argument(
        "--wavelength-nm", type=float, default=None, help="monochromatic halo (default: white)"
    )


def _render(args: argparse.Namespace) -> int:
    model = build_model(args)
    _log(f"reading {args.input}")
    image = read_exr(args.input)
    _log(f"{image.shape} image, max {float(image.max()):.4g} cd/m²; rendering with {model}")
    start = time.perf_counter()
    result = glare.render_glare(
        image,
        model,
        pixel_deg=args.pixel_deg,
        l_dmax_cd_m2=args.l_dmax,
        method=args.method,
        precision=args.precision,
    )
    left_image = result.energy_outside_image / np.maximum(result.excess_energy, 1e-300)
    _log(
        f"done in {time.perf_counter() - start:.2f} s; energy outside the kernel "
        f"{np.max(result.kernel.energy_outside):.3g}, outside the image "
        f"{float(np.max(left_image)):.3g} of the excess"
    )
    write_exr(args.output, result.image.astype(np.float32))
    _log(f"wrote {args.output}")
    if args.preview:
        preview_png(args.preview, result.image, l_dmax_cd_m2=args.l_dmax, scale=args.preview_scale)
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


def _demo(args: argparse.Namespace) -> int:
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


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glarelab", description="Glare illusion psychophysics suite"
    )
    commands = parser.add_subparsers(dest="command", required=True)

    render = commands.add_parser("render", help="add glare to a linear float EXR image")
    render.add_argument("input", type=Path, help="linear luminance EXR (Y or RGB), cd/m²")
    render.add_argument("output", type=Path, help="output EXR (float32)")
    render.add_argument("--pixel-deg", type=float, required=True, help="visual angle of a pixel")
    render.add_argument("--l-dmax", type=float, default=220.0, help="display maximum, cd/m²")
    render.add_argument("--method", choices=("Yoshida2008", "Spencer1995"), default="Yoshida2008")
    render.add_argument("--precision", choices=("float64", "float32"), default="float64")
    render.add_argument("--preview", type=Path, help="also write a PNG preview here")
    render.add_argument("--preview-scale", choices=("display", "log"), default="display")
    _add_model_options(render)
    render.set_defaults(run=_render)

    demo = commands.add_parser("demo", help="render a glare stimulus with each model")
    demo.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder")
    demo.set_defaults(run=_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``glarelab`` command; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except (ValueError, FileNotFoundError) as error:
        parser.error(f"{args.command}: {error}")
    return 2


if __name__ == "__main__":
    sys.exit(main())
