"""What the benchmark writes: the Markdown tables (ratios of times measured side by side) and
one Pareto plot per workload and model."""

from __future__ import annotations

import math
from pathlib import Path

from glarelab.bench.peers import PEER, PEER_SPECTRUM, PEER_SPECTRUM_32
from glarelab.files.atomic import write_bytes

__all__ = ["DEFAULT", "tables", "write_plots"]

DEFAULT = "default (renderer, plan, 0.5 codes)"
_RATIO = {  # a peer → the column of a row's speed against it (median of per-round ratios)
    PEER: "speed_vs_peer",
    PEER_SPECTRUM: "speed_vs_spectrum_peer",
    PEER_SPECTRUM_32: "speed_vs_spectrum_peer_32",
}


def _best_peer(mine: list[dict], bound: float) -> dict | None:
    """The fastest peer whose error is within ``bound`` codes."""
    peers = [
        r for r in mine if r["variant"].startswith("peer") and float(r["max_error_codes"]) <= bound
    ]
    return min(peers, key=lambda r: float(r["seconds"]), default=None)


def tables(
    rows: list[dict],
    spectral_rows: list[dict] = (),
    memory_rows: list[dict] = (),
    startup_rows: list[dict] = (),
) -> str:
    """Markdown: a summary per workload and model (the default against the exact render and
    the peers, as ratios of times measured in the same run), then every variant, then peak
    memory and the spectral section.

    Parameters
    ----------
    rows
        The rows of :func:`glarelab.bench.run.run_bench`: one per workload, model and
        variant.
    spectral_rows
        The rows of :func:`glarelab.bench.spectral.spectral_bench`; default none.
    memory_rows
        The rows of :func:`glarelab.bench.processes.memory_bench`; default none.
    startup_rows
        The rows of :func:`glarelab.bench.processes.startup_bench`; default none.

    Returns
    -------
    str
        The Markdown.
    """
    lines = [
        "| workload | model | default (s) | path | transforms | error (codes) | fastest peer "
        "within 0.5 codes | peer (s) | × faster than it | float32 spectrum peer: error "
        "(codes) | × faster than it | × faster than rfft2 with precomputed spectrum | × "
        "faster than full-kernel fftconvolve | × the floor's time |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for key in dict.fromkeys((r["workload"], r["model"]) for r in rows):
        mine = [r for r in rows if (r["workload"], r["model"]) == key]
        default = next(r for r in mine if r["variant"] == DEFAULT)
        best = _best_peer(mine, 0.5)
        single = next(r for r in mine if r["variant"] == PEER_SPECTRUM_32)
        speed = float(default["seconds"])
        best_ratio = (
            f"{float(best['seconds']) / speed:.2f}"
            if best["variant"] not in (PEER, PEER_SPECTRUM, PEER_SPECTRUM_32)
            else f"{float(default[_RATIO[best['variant']]]):.2f}"
        )
        lines.append(
            f"| {key[0]} | {key[1]} | {speed:.3f} | {default.get('path', '')} | "
            f"{default.get('transforms', '')} | {float(default['max_error_codes']):.2g} | "
            f"{best['variant'].removeprefix('peer: ')} | {float(best['seconds']):.3f} | "
            f"{best_ratio} | {float(single['max_error_codes']):.2g} | "
            f"{float(default['speed_vs_spectrum_peer_32']):.2f} | "
            f"{float(default['speed_vs_spectrum_peer']):.2f} | "
            f"{float(default['speed_vs_peer']):.2f} | "
            f"{1.0 / float(default['speed_vs_floor']):.2f} |"
        )
    lines += [
        "",
        "| workload | model | variant | time (s) | × rfft2-spectrum peer | × float32 spectrum "
        "peer | × fftconvolve peer | max error (codes) | RMS (codes) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    lines += [
        f"| {r['workload']} | {r['model']} | {r['variant']} | {float(r['seconds']):.3f} | "
        f"{float(r['speed_vs_spectrum_peer']):.2f} | "
        f"{float(r['speed_vs_spectrum_peer_32']):.2f} | {float(r['speed_vs_peer']):.2f} | "
        f"{float(r['max_error_codes']):.3g} | {float(r['rms_error_codes']):.3g} |"
        for r in rows
    ]
    if startup_rows:
        lines += [
            "",
            "| start-up | imports (s) | × import numpy, scipy.fft | process (s) | × its process |",
            "| --- | --- | --- | --- | --- |",
        ]
        lines += [
            f"| {r['case']} | {float(r['import_s']):.3f} | {float(r['import_ratio']):.2f} | "
            f"{float(r['process_s']):.3f} | {float(r['process_ratio']):.2f} |"
            for r in startup_rows
        ]
    if memory_rows:
        lines += ["", "| workload | variant | peak memory (MiB) |", "| --- | --- | --- |"]
        lines += [
            f"| {r['workload']} | {r['variant']} | {float(r['peak_mib']):.0f} |"
            for r in memory_rows
        ]
    if spectral_rows:
        lines += [
            "",
            "| PSF | variant | time (s) | × reference speed | mean ΔE00 | max ΔE00 "
            "| luminance error |",
            "| --- | --- | --- | --- | --- | --- | --- |",
        ]
        lines += [
            f"| {r['workload']} | {r['variant']} | {float(r['seconds']):.2f} | "
            f"{float(r['speed_vs_peer']):.2f} | {float(r['delta_e_mean']):.3g} | "
            f"{float(r['delta_e_max']):.3g} | {float(r['luminance_error']):.2g} |"
            for r in spectral_rows
        ]
    return "\n".join(lines) + "\n"


def write_plots(rows: list[dict], out: Path) -> None:
    """One Pareto PNG per workload and model, ``pareto_<workload>_<model>.png``.

    Parameters
    ----------
    rows
        The rows of :func:`glarelab.bench.run.run_bench`.
    out
        The folder the PNGs are written into.
    """
    for key in dict.fromkeys((r["workload"], r["model"]) for r in rows):
        results = [r for r in rows if (r["workload"], r["model"]) == key]
        title = f"{key[0]} / {key[1]}: time against error"
        _pareto(results, title, Path(out) / f"pareto_{key[0]}_{key[1]}.png")


def _pareto(results: list[dict], title: str, path: Path) -> None:
    """Time against largest error, one marker per variant (legend below the axes, where it
    takes no width from them), log-log; peers are squares, the plan's points are joined
    (its tolerance is the knob)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    from glarelab.analysis.figures import png, subplots

    floor = 1e-4  # errors below this are drawn on it (a log axis has no zero)
    markers = "oD^v<>pdX*P"  # squares are for peers; 11 against 10 colours: no pair twice
    figure, axis = subplots(figsize=(8.5, 5.0 + 0.16 * math.ceil((len(results) + 1) / 2)))
    plan = [r for r in results if r["variant"].startswith(("default", "plan"))]
    plan.sort(key=lambda r: r["seconds"])
    axis.plot(
        [r["seconds"] for r in plan],
        [max(r["max_error_codes"], floor) for r in plan],
        color="0.7",
        lw=1,
        zorder=1,
    )
    for index, r in enumerate(results):
        peer = r["variant"].startswith("peer")
        axis.scatter(
            r["seconds"],
            max(r["max_error_codes"], floor),
            s=42,
            marker="s" if peer else markers[index % len(markers)],
            label=r["variant"].removeprefix("peer: "),
            zorder=2,
            edgecolors="k" if r["variant"] == DEFAULT else "none",
        )
    axis.axhline(0.5, color="k", ls="--", lw=0.8, label="half a display code")
    axis.set(
        xscale="log",
        yscale="log",
        xlabel="time (s, best of the rounds, kernel digitised beforehand)",
        ylabel=f"max error (10-bit codes; < {floor:g} at {floor:g})",
        title=title,
    )
    axis.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.xaxis.set_minor_formatter(NullFormatter())  # minor labels collide on short spans
    axis.legend(
        fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncols=2, frameon=False
    )
    write_bytes(path, png(figure))
