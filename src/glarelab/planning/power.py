"""Power and sample size from simulated studies: the proportion of replications in which each
effect is significant, with its binomial confidence interval, the distribution of its effect
size, and the smallest sample size that reaches a target power.

:func:`power_analysis` runs a protocol's replications (:mod:`glarelab.planning.simulate`) on Dask
(:mod:`glarelab.planning.execute`) into a folder, resuming what is there, and writes:

- ``power.csv``: one row per effect and sample size: ``effect, participants, power, ci_low,
  ci_high, significant, replications, failed, p_used, lower_bound`` (``p_used``: which p judged
  it, :func:`glarelab.planning.effects.chosen_p`; ``lower_bound``: the share of replications in
  which sphericity was not estimable and the lower-bound correction was used);
- ``effect_sizes.csv``: per effect and sample size, the effect size's name, mean, SD and the
  5, 25, 50, 75 and 95 % quantiles over replications;
- ``recommended.csv``: per effect, the smallest sample size whose power reaches the target,
  and the smallest whose confidence interval lies wholly above it;
- ``power_curves.png`` and ``effect_sizes.png``;
- ``replications.jsonl`` (every replication's effects, as they finished) and ``run.json``
  (what the replications depend on; a rerun with other values is refused).

The five summaries are replaced together: the new folder is built beside ``out``, with the
folder's other files (the replications, a user's own files) hard-linked into it, and swapped
with ``out`` in one step, so that a run killed at any moment leaves the earlier summaries or the
new ones, never some of each (:func:`write_summary`). One run at a time writes into a folder:
it holds the lock ``.NAME.power.lock`` beside it (:class:`glarelab.files.locks.ProcessLock`,
released by the system however the process ends), and a second run is refused.

**Power** at sample size ``n`` is ``k / R``, ``k`` of ``R`` replications with ``p < α`` (a
replication whose analysis refused the data counts as not significant, and is counted in
``failed``). Its confidence interval is the exact binomial (Clopper–Pearson) interval,
:func:`statsmodels.stats.proportion.proportion_confint` with ``method="beta"``: at least the
stated coverage for every true power, where the normal approximation undercovers near 0 and 1.

References
----------
Clopper & Pearson (1934). The use of confidence or fiducial limits illustrated in the case of
the binomial. Biometrika 26.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from glarelab.files.atomic import write_bytes, write_text
from glarelab.files.folders import (
    LISTING,
    listed_files,
    output_lock,
    replace_folder,
    restore_folder,
    staging_folder,
)
from glarelab.files.inputs import loads_json
from glarelab.files.locks import ProcessLock
from glarelab.files.values import is_real
from glarelab.planning.effects import CORRECTIONS, SphericityChoice, chosen_p

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = [
    "binomial_interval",
    "check_run_folder",
    "effect_size_figure",
    "power_analysis",
    "power_figure",
    "recommend",
    "run_inputs",
    "summarise",
    "write_summary",
]

RUN_FORMAT = "glarelab power run v1"
MAX_PARTICIPANTS = 999
"""The largest sample size: participants are numbered with three digits
(:func:`glarelab.planning.simulate.participant_id`)."""
QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)


def binomial_interval(successes: int, trials: int, *, level: float = 0.95) -> tuple[float, float]:
    """The Clopper–Pearson interval of a proportion (statsmodels).

    Parameters
    ----------
    successes
        Replications that rejected the null hypothesis, ``0 <= successes <= trials``.
    trials
        Replications, >= 1.
    level
        Confidence level; default 0.95.

    Returns
    -------
    low, high : float
        The interval's bounds, proportions in [0, 1].

    Raises
    ------
    ValueError
        For counts that are not whole numbers or outside those ranges, or a level outside
        (0, 1) (95 is not 0.95).

    Examples
    --------
    >>> low, high = binomial_interval(80, 100)
    >>> round(low, 4), round(high, 4)
    (0.7082, 0.8733)
    """
    from statsmodels.stats.proportion import proportion_confint

    for name, value in (("successes", successes), ("trials", trials)):
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
            raise ValueError(f"{name} must be a whole number; got {value!r}")
    if trials < 1 or not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials, trials >= 1; got {successes}, {trials}")
    if not is_real(level) or not 0 < level < 1:  # a bool, a string, a complex number
        raise ValueError(f"level must be a confidence level in (0, 1), e.g. 0.95; got {level!r}")
    low, high = proportion_confint(successes, trials, alpha=1 - level, method="beta")
    return float(low), float(high)


def _check_alpha(alpha: float) -> float:
    if not is_real(alpha) or not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1); got {alpha!r}")
    return float(alpha)


def summarise(
    records: Sequence[dict],
    *,
    alpha: float = 0.05,
    correction: SphericityChoice = "gg",
    level: float = 0.95,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Power and effect-size tables from replications' records.

    Parameters
    ----------
    records
        One per replication, in replication order: ``results`` (rows with ``n``, ``effect``
        and the fields of :func:`glarelab.planning.effects.effects`) and ``failures``.
    alpha
        Significance level (default 0.05).
    correction
        How ANOVA effects are judged (:func:`glarelab.planning.effects.chosen_p`); default
        ``"gg"``, Greenhouse–Geisser's p, the more conservative: the reports decide by
        Girden's rule (``"girden"``: GG where ε < .75, else Huynh–Feldt), whose power is at
        least as high.
    level
        Confidence level of the power's interval (default 0.95).

    Returns
    -------
    power, sizes : pandas.DataFrame
        The tables of ``power.csv`` and ``effect_sizes.csv`` (module docstring), effects in
        the order the analysis reports them, sample sizes ascending.
    """
    alpha = _check_alpha(alpha)
    if correction not in CORRECTIONS:
        raise ValueError(f"correction must be one of {', '.join(CORRECTIONS)}; got {correction!r}")
    if not records:
        raise ValueError("no replications to summarise")
    total = len(records)
    order: dict[str, int] = {}
    cells: dict[tuple[str, int], dict] = {}
    sizes_n: set[int] = set()
    for record in records:
        for row in record["results"]:
            order.setdefault(row["effect"], len(order))
            cell = cells.setdefault(
                (row["effect"], row["n"]),
                {"significant": 0, "analysed": 0, "how": {}, "sizes": [], "name": ""},
            )
            p, how = chosen_p(row, correction)
            cell["analysed"] += 1
            cell["significant"] += p < alpha
            cell["how"][how] = cell["how"].get(how, 0) + 1
            if row.get("size") is not None:
                cell["sizes"].append(row["size"])
            cell["name"] = row.get("size_name", "")
            sizes_n.add(row["n"])
    power_rows, size_rows = [], []
    for (effect, n), cell in sorted(
        cells.items(), key=lambda item: (order[item[0][0]], item[0][1])
    ):
        low, high = binomial_interval(cell["significant"], total, level=level)
        used = sorted(cell["how"], key=lambda how: -cell["how"][how])
        power_rows.append(
            {
                "effect": effect,
                "participants": n,
                "power": cell["significant"] / total,
                "ci_low": low,
                "ci_high": high,
                "significant": cell["significant"],
                "replications": total,
                "failed": total - cell["analysed"],
                "p_used": "+".join(used),
                "lower_bound": cell["how"].get("lower bound", 0) / total,
            }
        )
        sizes = np.asarray(cell["sizes"], float)
        quantiles = np.quantile(sizes, QUANTILES) if sizes.size else [math.nan] * len(QUANTILES)
        size_rows.append(
            {
                "effect": effect,
                "participants": n,
                "size": cell["name"],
                "mean": float(sizes.mean()) if sizes.size else math.nan,
                "sd": float(sizes.std(ddof=1)) if sizes.size > 1 else math.nan,
                **{
                    f"q{round(100 * q):02d}": float(v)
                    for q, v in zip(QUANTILES, quantiles, strict=True)
                },
            }
        )
    return pd.DataFrame(power_rows), pd.DataFrame(size_rows)


def recommend(power: pd.DataFrame, *, target: float = 0.8) -> pd.DataFrame:
    """Per effect, the smallest sample size whose power reaches ``target`` (``n_power``) and
    the smallest whose confidence interval lies wholly above it (``n_confident``); empty where
    none of the sample sizes does.

    Parameters
    ----------
    power
        The power table (:func:`summarise`): ``effect``, ``participants``, ``power`` and
        ``ci_low``.
    target
        The power wanted, in (0, 1); default 0.8.

    Returns
    -------
    pandas.DataFrame
        One row per effect: ``effect``, ``target``, ``n_power``, ``n_confident`` (missing
        where not reached), ``power_at_largest`` and ``largest`` (the largest sample size
        simulated).

    Raises
    ------
    ValueError
        For a ``target`` that is not a number in (0, 1), or a ``power`` that is not a
        DataFrame with those columns.

    Examples
    --------
    >>> table = pd.DataFrame({"effect": ["a"] * 3, "participants": [6, 8, 10],
    ...                       "power": [0.7, 0.82, 0.9], "ci_low": [0.6, 0.78, 0.85]})
    >>> recommend(table, target=0.8)[["n_power", "n_confident"]].to_numpy().tolist()
    [[8, 10]]
    """
    if not is_real(target) or not 0 < target < 1:
        raise ValueError(f"target must be a number in (0, 1); got {target!r}")
    if not isinstance(power, pd.DataFrame):
        raise ValueError(
            f"power must be the power table (a DataFrame from summarise); got "
            f"{type(power).__name__}"
        )
    missing = [c for c in ("effect", "participants", "power", "ci_low") if c not in power]
    if missing:
        raise ValueError(
            f"power must have the columns effect, participants, power and ci_low (the table "
            f"summarise returns); it has no {', '.join(missing)}"
        )
    rows = []
    for effect, part in power.groupby("effect", sort=False):
        part = part.sort_values("participants")
        reached = part.loc[part["power"] >= target, "participants"]
        confident = part.loc[part["ci_low"] >= target, "participants"]
        rows.append(
            {
                "effect": effect,
                "target": target,
                "n_power": int(reached.iloc[0]) if len(reached) else pd.NA,
                "n_confident": int(confident.iloc[0]) if len(confident) else pd.NA,
                "power_at_largest": float(part["power"].iloc[-1]),
                "largest": int(part["participants"].iloc[-1]),
            }
        )
    table = pd.DataFrame(rows)
    return table.astype({"n_power": "Int64", "n_confident": "Int64"})


def _groups(effects: list[str]) -> dict[str, list[str]]:
    """Effects grouped for the figure's panels: by the analysis before ``:``."""
    groups: dict[str, list[str]] = {}
    for effect in effects:
        group = effect.split(":", 1)[0] if ":" in effect else effect.split(" ", 1)[0]
        groups.setdefault(group, []).append(effect)
    return groups


def _panels(effects: pd.Series, **options):
    """The effects grouped by :func:`_groups` (in order of appearance) and a figure with a
    panel for each group, two columns at most; ``options`` go to
    :func:`glarelab.analysis.figures.subplots`."""
    from glarelab.analysis.figures import subplots

    groups = _groups(list(dict.fromkeys(effects)))
    columns = min(len(groups), 2)  # a page's width (6.5 in) at 8 pt and more
    rows = math.ceil(len(groups) / columns)
    figure, axes = subplots(
        rows, columns, figsize=(3.3 * columns, 3.4 * rows), squeeze=False, **options
    )
    return groups, figure, axes


def _legend_below(axis) -> None:
    """The panel's legend under its axis label, outside the plot: never over a curve."""
    axis.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.22), frameon=False)


def power_figure(power: pd.DataFrame, *, target: float, alpha: float, title: str) -> bytes:
    """Power curves with their confidence intervals, one panel per analysis (PNG bytes).

    Parameters
    ----------
    power
        The power table (:func:`summarise`).
    target
        The power wanted, drawn as a dashed line.
    alpha
        The significance level, drawn as a dotted line (the power of no effect).
    title
        The figure's title (the study's).

    Returns
    -------
    bytes
        The PNG file's content.
    """
    from glarelab.analysis.figures import png

    groups, figure, axes = _panels(power["effect"], sharey=True)
    for axis, (group, members) in zip(axes.flat, groups.items(), strict=False):
        for effect in members:
            part = power[power["effect"] == effect]
            label = effect.split(":", 1)[1].strip() if ":" in effect else effect
            axis.errorbar(
                part["participants"],
                part["power"],
                yerr=[part["power"] - part["ci_low"], part["ci_high"] - part["power"]],
                marker="o",
                ms=3,
                capsize=2,
                label=label,
            )
        axis.set_xticks(sorted(power["participants"].unique()))
        axis.axhline(target, color="k", ls="--", lw=0.8)
        axis.axhline(alpha, color="grey", ls=":", lw=0.8)
        axis.set_ylim(-0.02, 1.02)
        axis.set_title(group, fontsize=9)
        axis.set_xlabel("participants")
        _legend_below(axis)
    for axis in axes.flat[len(groups) :]:
        axis.set_axis_off()
    for axis in axes[:, 0]:
        axis.set_ylabel("power")
    replications = int(power["replications"].iloc[0])
    figure.suptitle(
        f"{title}: power (α = {alpha:g}; dashed: target {target:g})\n"
        f"{replications} simulated studies per point, 95 % CI",
        fontsize=10,
    )
    return png(figure)


def effect_size_figure(sizes: pd.DataFrame, *, title: str) -> bytes:
    """Median effect size with its 5-95 % and 25-75 % ranges against the sample size, one
    panel per analysis (PNG bytes).

    Parameters
    ----------
    sizes
        The effect-size table (:func:`summarise`): the quantiles ``q05`` … ``q95`` of each
        effect's size at each sample size, and the size's name.
    title
        The figure's title (the study's).

    Returns
    -------
    bytes
        The PNG file's content.
    """
    from glarelab.analysis.figures import png

    groups, figure, axes = _panels(sizes["effect"])
    for axis, (group, members) in zip(axes.flat, groups.items(), strict=False):
        width = 0.8 / len(members)
        for index, effect in enumerate(members):
            part = sizes[sizes["effect"] == effect]
            x = np.arange(len(part)) + (index - (len(members) - 1) / 2) * width
            label = effect.split(":", 1)[1].strip() if ":" in effect else effect
            axis.vlines(x, part["q05"], part["q95"], lw=0.8, color=f"C{index % 10}")
            axis.vlines(x, part["q25"], part["q75"], lw=3, color=f"C{index % 10}")
            axis.plot(x, part["q50"], "o", ms=3, color=f"C{index % 10}", label=label)
            axis.set_xticks(np.arange(len(part)), part["participants"])
        axis.set_title(group, fontsize=9)
        axis.set_xlabel("participants")
        axis.set_ylabel(sizes.loc[sizes["effect"] == members[0], "size"].iloc[0], fontsize=8)
        _legend_below(axis)
    for axis in axes.flat[len(groups) :]:
        axis.set_axis_off()
    figure.suptitle(f"{title}: effect sizes\n(median, 25-75 %, 5-95 %)", fontsize=10)
    return png(figure)


def write_summary(
    out: Path,
    records: Sequence[dict],
    *,
    alpha: float,
    correction: SphericityChoice,
    target: float,
    title: str,
) -> pd.DataFrame:
    """Write ``power.csv``, ``effect_sizes.csv``, ``recommended.csv`` and the two figures into
    ``out``, replacing the earlier five together; return the recommendations.

    The new folder is built whole beside ``out``: its other files (``run.json``,
    ``replications.jsonl``, a user's own) hard-linked into it (copied where the file system
    cannot link), the five summaries written, and the two folders swapped in one step
    (:func:`glarelab.files.folders.replace_folder`). A process killed at any moment leaves
    the earlier five or the new five, never some of each; a full disk leaves the earlier ones.
    Nothing else may write into ``out`` meanwhile (:func:`power_analysis` holds its lock).

    Parameters
    ----------
    out
        The run's folder.
    records
        The replications' records, in replication order (:func:`summarise`).
    alpha, correction, target
        Significance level, how ANOVA effects are judged
        (:func:`glarelab.planning.effects.chosen_p`) and the power wanted.
    title
        The figures' title (the study's).

    Returns
    -------
    pandas.DataFrame
        The recommendations (:func:`recommend`).
    """
    power, sizes = summarise(records, alpha=alpha, correction=correction)
    recommended = recommend(power, target=target)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    # all made before the first is written
    files = {
        "power.csv": power.to_csv(index=False, float_format="%.6g").encode(),
        "effect_sizes.csv": sizes.to_csv(index=False, float_format="%.6g").encode(),
        "recommended.csv": recommended.to_csv(index=False, float_format="%.6g").encode(),
        "power_curves.png": power_figure(power, target=target, alpha=alpha, title=title),
        "effect_sizes.png": effect_size_figure(sizes, title=title),
    }
    written = {*listed_files(out), *files, "run.json", "replications.jsonl"}
    staging = staging_folder(out)
    try:
        _link_tree(out, staging)
        for name, data in files.items():
            write_bytes(staging / name, data)
        replace_folder(staging, out, kind="power", files=written)
    finally:
        shutil.rmtree(staging, ignore_errors=True)  # a failed build, or the earlier folder
    return recommended


def _link_tree(source: Path, target: Path) -> None:
    """Every file under ``source`` but its listing, in ``target``: hard-linked (the content is
    not copied, and a file appended to later stays one file), or copied where the file system
    cannot link; symbolic links as links."""
    failed: list[OSError] = []

    def link(source_file: str, target_file: str) -> None:
        try:
            os.link(source_file, target_file)
        except OSError:
            try:
                shutil.copy2(source_file, target_file)
            except OSError as error:
                failed.append(error)
                raise

    top = os.fspath(source)
    try:
        shutil.copytree(
            source,
            target,
            symlinks=True,
            copy_function=link,
            ignore=lambda folder, names: [LISTING] if folder == top else [],
            dirs_exist_ok=True,
        )
    except shutil.Error:
        if failed:  # with its errno (a full disk), which shutil.Error's summary drops
            raise failed[0] from None
        raise


def _folder_lock(out: Path) -> ProcessLock:
    """The lock of a power run's folder: a file beside it (the folder itself is swapped)."""
    return output_lock(out, "power run", suffix="power")


def run_inputs(
    protocol: Protocol,
    *,
    seed: int,
    participants: Sequence[int],
    stimuli_sha256: str | None = None,
) -> dict:
    """What a folder's replications depend on (its ``run.json``): the protocol, the seed,
    the sample sizes and the stimulus set the observers look at. The number of replications
    is not among them: more can be added later, and fewer summarised.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study; its name and hash are recorded.
    seed
        The simulated observers' seed.
    participants
        The sample sizes; recorded sorted, each once.
    stimuli_sha256
        The sha256 of the stimulus set's manifest (:func:`stimuli_sha256`), or None: not
        recorded (a protocol that shows no images; a check before the set is known).

    Returns
    -------
    dict
        ``format``, ``study``, ``protocol_sha256``, ``seed``, ``participants`` and, when
        given, ``stimuli_sha256``.
    """
    run = {
        "format": RUN_FORMAT,
        "study": protocol.study,
        "protocol_sha256": protocol.sha256,
        "seed": seed,
        "participants": sorted(set(int(n) for n in participants)),
    }
    return run if stimuli_sha256 is None else run | {"stimuli_sha256": stimuli_sha256}


def stimuli_sha256(stimuli: str | Path) -> str:
    """The sha256 of a stimulus set's ``manifest.json``: a resumed run on another set (of
    another calibration) mixed its replications with the first set's.

    Parameters
    ----------
    stimuli
        The set's folder.

    Returns
    -------
    str
        Hex digest.
    """
    return hashlib.sha256((Path(stimuli) / "manifest.json").read_bytes()).hexdigest()


def check_run_folder(out: str | Path, run: dict) -> None:
    """Refuse a folder whose replications were made with other inputs (writes nothing).

    Parameters
    ----------
    out
        The run's folder; without a ``run.json``, nothing is refused.
    run
        This run's inputs (:func:`run_inputs`).

    Raises
    ------
    ValueError
        Naming the folder and each input that differs.
    """
    path = Path(out) / "run.json"
    if not path.is_file():
        return
    try:
        before = loads_json(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(
            f"{path} is not valid JSON ({error}): delete the folder to start again"
        ) from None
    if not isinstance(before, dict):
        raise ValueError(f"{path} must be a JSON object: delete the folder to start again")
    changed = [
        f"{key} {before.get(key)!r} then, {value!r} now"
        for key, value in run.items()
        if before.get(key) != value
    ]
    if changed:
        raise ValueError(
            f"{out} holds replications made with other inputs ({'; '.join(changed)}): give "
            "another --out, or delete it to start again"
        )


def _check_stimuli(stimuli: Path, protocol: Protocol) -> None:
    """Refuse a stimulus set that is damaged or of another protocol."""
    from glarelab.stimuli.stimulus_set import verify_stimulus_set

    problems = verify_stimulus_set(stimuli)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ValueError(f"stimuli {stimuli}: not an intact stimulus set: {problems[0]}{more}")
    path = Path(stimuli) / "manifest.json"
    manifest = loads_json(path.read_text(encoding="utf-8"), source=path)
    if manifest.get("protocol_sha256") != protocol.sha256:
        raise ValueError(
            f"stimuli {stimuli}: built from another protocol than {protocol.study}'s (its "
            "manifest's protocol_sha256 differs); give the set of this protocol, or none"
        )


def power_analysis(
    protocol: Protocol,
    out: str | Path,
    *,
    participants: Sequence[int],
    replications: int,
    seed: int,
    alpha: float = 0.05,
    correction: SphericityChoice = "gg",
    target: float = 0.8,
    stimuli: Path | None = None,
    client=None,
    scratch: Path | None = None,
    log: Callable[[str], None] = print,
    progress=True,
    task_delay_s: float = 0.0,
) -> pd.DataFrame:
    """Estimate the power of every effect of a protocol's analysis at each sample size.

    Parameters
    ----------
    protocol
        The study (:func:`glarelab.protocols.load_protocol`).
    out
        Output folder (module docstring); a folder with replications of the same inputs is
        resumed.
    participants
        Sample sizes (each >= 2).
    replications
        Simulated studies per sample size (>= 1).
    seed
        The simulated observers' seed: with it, the results are the same on any number of
        workers and after any interruption.
    alpha, correction, target
        Significance level, how ANOVA effects are judged
        (:func:`glarelab.planning.effects.chosen_p`) and the power wanted (for
        ``recommended.csv``).
    stimuli
        The protocol's stimulus set (default: built once into the cache,
        :func:`glarelab.stimuli.stimulus_set.cached_stimulus_set`).
    client
        A :class:`distributed.Client` (:func:`glarelab.planning.execute.dask_client`), or None to
        run here without Dask.
    scratch
        Folder for the simulated sessions' files (default
        :func:`glarelab.planning.simulate.default_scratch`, on each worker).
    log, progress
        Progress messages, and whether to show the progress bar.
    task_delay_s
        Seconds each replication waits before it runs, default 0: for tests that stop a run
        part way (the command's hidden ``--task-delay-ms``).

    Returns
    -------
    pandas.DataFrame
        The recommendations (``recommended.csv``).

    Raises
    ------
    ValueError
        For bad arguments (named), an ``out`` holding replications of other inputs, or one
        that another power run is writing into (naming its process and host).
    """
    from glarelab.planning.execute import Progress, ResultLog, run_tasks
    from glarelab.planning.simulate import PowerJob
    from glarelab.stimuli.stimulus_set import cached_stimulus_set, shows_images

    sizes = sorted(set(int(n) for n in participants))
    if not sizes or sizes[0] < 2 or sizes[-1] > MAX_PARTICIPANTS:
        raise ValueError(
            f"participants must be sample sizes from 2 to {MAX_PARTICIPANTS}; got "
            f"{list(participants)!r}"
        )
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a whole number >= 0; got {seed!r}")
    if isinstance(replications, bool) or not isinstance(replications, int) or replications < 1:
        raise ValueError(f"replications must be an integer >= 1; got {replications!r}")
    _check_alpha(alpha)
    if correction not in CORRECTIONS:
        raise ValueError(f"correction must be one of {', '.join(CORRECTIONS)}; got {correction!r}")
    if not 0 < target < 1:
        raise ValueError(f"target must be in (0, 1); got {target!r}")
    if stimuli is not None and not shows_images(protocol):
        raise ValueError(
            f"stimuli: the {protocol.study} protocol's paradigm ({protocol.paradigm}) shows no "
            "images; give no stimulus set"
        )
    if stimuli is not None:
        _check_stimuli(Path(stimuli), protocol)
    out = Path(out)
    with _folder_lock(out):
        restore_folder(out)
        check_run_folder(out, run_inputs(protocol, seed=seed, participants=sizes))
        if shows_images(protocol) and stimuli is None:
            log(f"building (or reusing) the {protocol.study} stimulus set the observers look at")
            stimuli = cached_stimulus_set(protocol, progress=None)
        run = run_inputs(
            protocol,
            seed=seed,
            participants=sizes,
            stimuli_sha256=None if stimuli is None else stimuli_sha256(stimuli),
        )
        check_run_folder(out, run)  # the set's too: a resume on another set is refused
        out.mkdir(parents=True, exist_ok=True)
        if not (out / "run.json").is_file():
            write_text(out / "run.json", json.dumps(run, indent=2, sort_keys=True) + "\n")
        job = PowerJob(
            protocol,
            participants=tuple(sizes),
            seed=seed,
            stimuli=stimuli,
            scratch=scratch,
            task_delay_s=task_delay_s,
        )
        key = hashlib.sha256(json.dumps(run, sort_keys=True).encode()).hexdigest()
        with ResultLog(out / "replications.jsonl", key=key) as results:
            done = sum(r in results for r in range(replications))
            if done:
                log(f"resuming: {done} of {replications} replications already in {out}")
            run_tasks(
                job,
                range(replications),
                results,
                client=client,
                what="replications",
                progress=Progress if progress else None,
            )
            records = results.sorted(range(replications))
        # the log is closed: its file is linked into the new folder as it stands
        return write_summary(
            out,
            records,
            alpha=alpha,
            correction=correction,
            target=target,
            title=protocol.study,
        )
