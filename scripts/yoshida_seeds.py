"""Yoshida 2008 §5 as many seeded studies: the distribution of each statistic over simulated
10-observer studies, next to the paper's.

Each seed is one study as ``glarelab demo --protocol yoshida2008`` runs it (seed 1 is the demo):
participants ``sim01`` … ``sim10`` through the session loop a lab session uses
(:func:`glarelab.experiments.session.run_session` driven by
:func:`glarelab.experiments.session.make_observer`), their CSVs through the protocol's own analysis
(``tests(dataset, protocol)``) and its tests read as effects
(:func:`glarelab.planning.effects.effects`), as ``glarelab power`` reads them. Run from the
repository's root (about 1 s per study on one core):

    python scripts/yoshida_seeds.py --seeds 200 --out docs/observers

writes ``yoshida_seeds.csv`` (one row per seed: every F, Welch's t at D, E, F and their
uncorrected and Greenhouse–Geisser p), ``yoshida_seeds.md`` (median and 90 % interval of each
statistic, how often it is significant, the paper's value and the demo's) and
``yoshida_seeds.png``. Without ``--stimuli`` the Yoshida set is built once (synthetic
calibration, as the demo builds it) into the cache (``$GLARELAB_CACHE`` or
``~/.cache/glarelab``).
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]

from matplotlib.lines import Line2D  # noqa: E402

from glarelab.analysis.figures import png, subplots  # noqa: E402
from glarelab.analysis.load import load_sessions  # noqa: E402
from glarelab.analysis.paradigms import PARADIGMS  # noqa: E402
from glarelab.observers.looking import ObservedSet  # noqa: E402
from glarelab.planning.effects import effects  # noqa: E402
from glarelab.planning.simulate import _simulate_sessions, default_scratch  # noqa: E402
from glarelab.protocols import load_protocol  # noqa: E402
from glarelab.stimuli.stimulus_set import StimulusSet, cached_stimulus_set  # noqa: E402

ALPHA = 0.05
STATISTICS = {  # key: (what the analysis calls it, Yoshida 2008 §5, the paper's df)
    "level": ("all levels: L_disk", 23.68, "F(5, 45)"),
    "method": ("all levels: method", 1.64, "F(1, 9)"),
    "interaction": ("all levels: L_disk × method", 7.77, "F(5, 45)"),
    "method_ABC": ("{A, B, C}: method", 1.4, "F(1, 9)"),
    "interaction_ABC": ("{A, B, C}: L_disk × method", 1.34, "F(2, 18)"),
    "method_DEF": ("{D, E, F}: method", 11.96, "F(1, 9)"),
    "interaction_DEF": ("{D, E, F}: L_disk × method", 0.28, "F(2, 18)"),
    "t_D": ("t-test D/d: Welch", 1.71, "t(14)"),
    "t_E": ("t-test E/e: Welch", 1.73, "t(14)"),
    "t_F": ("t-test F/f: Welch", 1.96, "t(14)"),
}
PAPER_P = {  # §5, as printed
    "level": "p < .001",
    "method": "n.s.",
    "interaction": "p < .001",
    "method_ABC": "n.s.",
    "interaction_ABC": "n.s.",
    "method_DEF": "p < .01",
    "interaction_DEF": "n.s.",
    "t_D": "p = .05",
    "t_E": "p = .05",
    "t_F": "p < .05",
}
NAMES = {
    "level": "L_disk",
    "method": "method",
    "interaction": "L_disk × method",
    "method_ABC": "method in {A, B, C}",
    "interaction_ABC": "L_disk × method in {A, B, C}",
    "method_DEF": "method in {D, E, F}",
    "interaction_DEF": "L_disk × method in {D, E, F}",
    "t_D": "Gaussian − Vos at D, Welch",
    "t_E": "Gaussian − Vos at E, Welch",
    "t_F": "Gaussian − Vos at F, Welch",
}


def _key(effect: str) -> str | None:
    """The :data:`STATISTICS` key of one of the analysis's effects (None for the others)."""
    analysis, _, source = effect.partition(": ")
    if analysis.startswith("t-test"):
        if "(Welch" not in source:
            return None
        level = analysis.removeprefix("t-test ").split("/")[0]
        return f"t_{level}" if f"t_{level}" in STATISTICS else None
    for group, suffix in (("(all levels)", ""), ("({A, B, C})", "_ABC"), ("({D, E, F})", "_DEF")):
        if analysis.endswith(group):
            key = {"L_disk": "level", "method": "method", "L_disk × method": "interaction"}.get(
                source
            )
            if key is None or (suffix and key == "level"):
                return None
            return key + suffix
    return None


def one_study(protocol, seed: int, participants: int, stimuli: Path, displayed) -> dict:
    """One seeded study as the demo runs it: every statistic of :data:`STATISTICS` with its
    uncorrected and Greenhouse–Geisser p."""
    folder = Path(tempfile.mkdtemp(prefix="glarelab-seeds-", dir=default_scratch()))
    try:
        ids = [f"sim{number:02d}" for number in range(1, participants + 1)]
        csvs = _simulate_sessions(
            protocol, ids, seed=seed, out=folder, stimuli=stimuli, looks_at=displayed
        )
        dataset = load_sessions(protocol, csvs)
        tables = PARADIGMS[protocol.paradigm].tests(dataset, protocol)
        rows = effects(protocol, tables, participants)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    out: dict = {"seed": seed}
    for row in rows:
        key = _key(row["effect"])
        if key is None:
            continue
        out[key] = row["statistic"]
        out[f"p_{key}"] = row["p"]
        gg = row.get("p_gg")
        out[f"p_gg_{key}"] = row["p"] if gg is None or row["test"] != "F" else gg
    missing = sorted(set(STATISTICS) - set(out))
    if missing:
        raise SystemExit(f"the analysis did not report {', '.join(missing)} (seed {seed})")
    return out


def summarise(frame: pd.DataFrame) -> pd.DataFrame:
    """Per statistic: the paper's value, median and 90 % interval over seeds, the share of
    seeds significant (uncorrected and Greenhouse–Geisser), where the paper falls among the
    seeds (its percentile) and the demo's (seed 1) value."""
    rows = []
    for key, (_, paper, df) in STATISTICS.items():
        x = frame[key].to_numpy(dtype=float)
        rows.append(
            {
                "statistic": key,
                "name": NAMES[key],
                "df": df,
                "paper": paper,
                "paper_p": PAPER_P[key],
                "median": float(np.median(x)),
                "p05": float(np.percentile(x, 5)),
                "p95": float(np.percentile(x, 95)),
                "significant": float(np.mean(frame[f"p_{key}"] < ALPHA)),
                "significant_gg": float(np.mean(frame[f"p_gg_{key}"] < ALPHA)),
                "paper_percentile": float(100 * np.mean(x < paper)),
                "demo": float(frame.loc[frame["seed"] == 1, key].iloc[0])
                if (frame["seed"] == 1).any()
                else math.nan,
            }
        )
    return pd.DataFrame(rows)


def pattern_rate(frame: pd.DataFrame) -> float:
    """The share of studies whose seven F tests are significant (uncorrected p < .05) exactly
    where §5's are: L_disk, the interaction and the method in {D, E, F}, and none of the
    others."""
    keys = [k for k in STATISTICS if not k.startswith("t_")]
    agree = np.ones(len(frame), dtype=bool)
    for key in keys:
        agree &= (frame[f"p_{key}"].to_numpy() < ALPHA) == (PAPER_P[key] != "n.s.")
    return float(np.mean(agree))


def markdown(summary: pd.DataFrame, seeds: int, participants: int, pattern: float) -> str:
    lines = [
        f"Over {seeds} seeded studies of {participants} simulated observers each "
        "(`scripts/yoshida_seeds.py`; seed 1 is `glarelab demo`):",
        "",
        "| statistic | Yoshida 2008 §5 | simulated median [5 %, 95 %] | p < .05 in (GG) | "
        "paper's percentile | demo (seed 1) |",
        "|---|---|---|---|---|---|",
    ]
    for row in summary.itertuples():
        lines.append(
            f"| {row.name}, {row.df} | {row.paper:.2f}, {row.paper_p} | "
            f"{row.median:.2f} [{row.p05:.2f}, {row.p95:.2f}] | "
            f"{100 * row.significant:.0f} % ({100 * row.significant_gg:.0f} %) | "
            f"{row.paper_percentile:.0f} | {row.demo:.2f} |"
        )
    lines += [
        "",
        "p < .05 in: the share of studies with p < .05 uncorrected (the paper's degrees of "
        "freedom are uncorrected) and, in brackets, Greenhouse–Geisser corrected; Welch's t "
        "one-sided, as in §5. The paper's percentile: the share of simulated studies below "
        "the paper's value.",
        "",
        f"The seven F tests are significant exactly where §5's are (L_disk, the interaction "
        f"and the method in {{D, E, F}}, none of the others) in {100 * pattern:.0f} % of the "
        "studies.",
    ]
    return "\n".join(lines) + "\n"


def figure(frame: pd.DataFrame, summary: pd.DataFrame):
    keys = [k for k in STATISTICS if not k.startswith("t_")]
    fig, axes = subplots(1, len(keys), figsize=(2.2 * len(keys), 3.8))
    rng = np.random.default_rng(0)  # jitter of the points only
    for axis, key in zip(axes, keys, strict=True):
        row = summary.set_index("statistic").loc[key]
        x = frame[key].to_numpy(dtype=float)
        jitter = rng.uniform(-0.25, 0.25, x.size)
        significant = frame[f"p_{key}"].to_numpy() < ALPHA
        axis.scatter(jitter[significant], x[significant], s=6, color="C3", alpha=0.5)
        axis.scatter(jitter[~significant], x[~significant], s=6, color="C0", alpha=0.5)
        axis.errorbar(
            [0.45],
            [row["median"]],
            yerr=[[row["median"] - row["p05"]], [row["p95"] - row["median"]]],
            fmt="ks",
            capsize=4,
        )
        axis.plot([0.45], [row["paper"]], "*", color="gold", mec="k", ms=13)
        axis.set_yscale("log")
        axis.set_xlim(-0.5, 0.8)
        axis.set_xticks([])
        title = NAMES[key].replace(" in ", "\nin ")
        axis.set_title(f"{title}, {row['df']}", fontsize=8)
    axes[0].set_ylabel("F (log scale)")
    handles = [
        Line2D([], [], ls="", marker="o", color="C3", label="a study, p < .05"),
        Line2D([], [], ls="", marker="o", color="C0", label="a study, n.s."),
        Line2D([], [], ls="", marker="s", color="k", label="median, 90 % interval"),
        Line2D([], [], ls="", marker="*", color="gold", mec="k", ms=11, label="Yoshida §5"),
    ]
    fig.legend(
        handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False, borderaxespad=0.2
    )
    fig.subplots_adjust(bottom=0.14, top=0.86, left=0.05, right=0.99, wspace=0.55)
    return fig


def _write(path: Path, data: bytes) -> None:
    """Write to a temporary name and rename when complete."""
    partial = path.with_name(f".{path.name}.partial")
    partial.write_bytes(data)
    os.replace(partial, path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=200, help="how many studies (seeds 1..N)")
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--participants", type=int, default=10)
    parser.add_argument("--stimuli", type=Path, default=None, help="a built Yoshida set")
    parser.add_argument("--out", type=Path, default=Path("out/yoshida_seeds"))
    parser.add_argument(
        "--summarise",
        type=Path,
        default=None,
        metavar="CSV",
        help="summarise a yoshida_seeds.csv written before (no simulation)",
    )
    args = parser.parse_args(argv)
    if args.summarise is not None:
        frame = pd.read_csv(args.summarise)
        write_summary(frame, args.out, int(frame["participants"].iloc[0]))
        return 0
    if args.seeds < 1:
        parser.error(f"--seeds must be >= 1; got {args.seeds}")
    if args.participants < 2:
        parser.error(f"--participants must be >= 2; got {args.participants}")
    protocol = load_protocol("yoshida2008")
    stimuli = args.stimuli or cached_stimulus_set(protocol)
    displayed = ObservedSet(StimulusSet(stimuli))
    started = time.time()
    rows = []
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    for done, seed in enumerate(seeds, start=1):
        rows.append(one_study(protocol, seed, args.participants, stimuli, displayed))
        if done % 10 == 0 or done == args.seeds:
            elapsed = time.time() - started
            print(
                f"  {done}/{args.seeds} studies, {elapsed:.0f} s "
                f"(about {elapsed / done * (args.seeds - done):.0f} s to go)",
                flush=True,
            )
    frame = pd.DataFrame(rows)
    frame.insert(1, "participants", args.participants)
    args.out.mkdir(parents=True, exist_ok=True)
    _write(
        args.out / "yoshida_seeds.csv", frame.to_csv(index=False, float_format="%.17g").encode()
    )
    write_summary(frame, args.out, args.participants)
    print(f"done in {time.time() - started:.0f} s; wrote {args.out}")
    return 0


def write_summary(frame: pd.DataFrame, out: Path, participants: int) -> None:
    """``yoshida_seeds.md`` and ``yoshida_seeds.png`` of the studies in ``frame``."""
    summary = summarise(frame)
    out.mkdir(parents=True, exist_ok=True)
    text = markdown(summary, len(frame), participants, pattern_rate(frame))
    _write(out / "yoshida_seeds.md", text.encode())
    _write(out / "yoshida_seeds.png", png(figure(frame, summary)))
    print(text)


if __name__ == "__main__":
    raise SystemExit(main())
