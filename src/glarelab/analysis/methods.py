"""What every methods paragraph and report shares: the display as the text names it, and the
data's provenance."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import TYPE_CHECKING

from glarelab.files.inputs import loads_json
from glarelab.files.values import is_whole

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["display_text", "provenance", "session_rows"]


def display_text(protocol: Protocol) -> str:
    """The display and viewing conditions, as the methods section names them.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol: its ``[display]`` and ``[viewing]``.

    Returns
    -------
    str
        A phrase: the display's name, size, resolution, bits and maximum, the viewing
        distance and the room's illumination.
    """
    d, v = protocol["display"], protocol["viewing"]
    size = (
        f"{d['diagonal_in']:g}-inch"
        if d["diagonal_in"] is not None
        else f"{d['pixel_pitch_mm']:g} mm pixel pitch"
    )
    return (
        f"a {d['name']} ({size}, {d['resolution_px'][0]} × {d['resolution_px'][1]} px, "
        f"{d['bit_depth']}-bit, maximum {d['max_cd_m2']:g} cd/m²) viewed from "
        f"{v['distance_m']:g} m in {v['room_lux']:g} lx"
    )


def provenance(
    sidecars: dict[str, dict], protocol_sha256: str | None, stimuli: Path | None
) -> dict:
    """Hashes and versions behind the data, session by session: protocol, calibration,
    encoding, packages, simulated or not; and what the sessions share or not.

    ``simulated`` is true when every session is simulated, false when none is, and
    ``"mixed"`` otherwise (``sessions`` says which); a session whose CSV came without its
    sidecar is listed with status ``"no sidecar"`` and ``simulated`` null (unknown).

    Parameters
    ----------
    sidecars
        CSV → its session's sidecar.
    protocol_sha256
        The analysed protocol's hash; None: not compared.
    stimuli
        The stimulus set's folder; None: none given.

    Returns
    -------
    dict
        ``sessions`` (one record per session) and what they share (``simulated``, the
        hashes and versions).
    """
    sessions = [
        {
            "file": Path(name).name,
            "participant": s.get("participant"),
            "session": s.get("session"),
            "status": s.get("status"),
            "simulated": s.get("simulated") if isinstance(s.get("simulated"), bool) else None,
            "protocol_sha256": s.get("protocol_sha256"),
            "stimulus_set_manifest_sha256": s.get("stimulus_set_manifest_sha256"),
            "calibration": s.get("calibration"),
            "images_encoded_with": s.get("images_encoded_with"),
            "glarelab": (s.get("packages") or {}).get("glarelab"),
        }
        for name, s in sidecars.items()
    ]
    flags = {s["simulated"] for s in sessions}
    simulated = next(iter(flags)) if len(flags) == 1 else "mixed"  # None: no sidecar says
    calibrations = {json.dumps(s["calibration"], sort_keys=True, default=str) for s in sessions}
    record = {
        "protocol_sha256": protocol_sha256,
        "protocol_sha256_in_sessions": sorted({s["protocol_sha256"] for s in sessions} - {None}),
        "stimulus_set_manifest_sha256_in_sessions": sorted(
            {s["stimulus_set_manifest_sha256"] for s in sessions} - {None}
        ),
        "simulated": simulated if sessions else None,
        "calibrations_in_sessions": len(calibrations),
        "packages": {
            name: sorted({(s.get("packages") or {}).get(name) or "?" for s in sidecars.values()})
            for name in sorted({k for s in sidecars.values() for k in s.get("packages") or {}})
        },
        "sessions": sessions,
    }
    if stimuli is not None:
        manifest = Path(stimuli) / "manifest.json"
        if not manifest.is_file():
            raise ValueError(f"--stimuli {stimuli}: no manifest.json (not a stimulus set?)")
        data = loads_json(manifest.read_text(), source=manifest)
        record["stimulus_set_manifest_sha256"] = hashlib.sha256(manifest.read_bytes()).hexdigest()
        record["stimulus_set_calibration_sha256"] = data.get("calibration_sha256")
        record["stimulus_set_calibration_status"] = data.get("calibration", {}).get("status")
    return record


def _hash(value: str | None, expected: str | None) -> str:
    if not value:
        return "—"
    return f"{value[:12]}{' ✓' if expected and value == expected else ''}"


def _time(value: str | None, since: str | None = None) -> str:
    """An ISO time as ``2026-11-30 14:32:05+01:00``; only the time if on ``since``'s date."""
    if not value:
        return "—"
    date, _, time = value.partition("T")
    return time if since and since.startswith(date) else f"{date} {time}"


def _count(value) -> int | str:
    """A session number or a count as the table prints it: a whole number, or — (never
    pandas' ``nan``, nor ``1.0`` where one row lacked it)."""
    return int(value) if is_whole(value) else "—"


def session_rows(
    files: list[str],
    sidecars: dict[str, dict],
    protocol_sha256: str | None,
    stimuli_sha256: str | None,
) -> list[dict]:
    """One row per session file, as the report's Sessions table shows it: who, when, how it
    ended (status "no sidecar" where the CSV came without one), and the hashes and versions it
    ran with, shortened (a ✓ after a hash that matches the analysis's protocol or stimulus
    set). :func:`provenance` keeps them whole.

    Parameters
    ----------
    files
        The session CSVs, in order; a CSV without a sidecar has no row here.
    sidecars
        CSV → its session's sidecar.
    protocol_sha256
        The analysed protocol's hash, to mark matching sessions; None: not marked.
    stimuli_sha256
        The stimulus set's manifest hash, likewise.

    Returns
    -------
    list of dict
        The table's rows.
    """
    rows = []
    for file in files:
        sidecar = sidecars.get(file)
        if sidecar is None:
            continue
        calibration = sidecar.get("calibration") or {}
        packages = sidecar.get("packages") or {}
        runs = sidecar.get("runs") or []
        rows.append(
            {
                "file": Path(file).name,
                "participant": sidecar.get("participant"),
                "session": _count(sidecar.get("session")),
                "status": sidecar.get("status"),
                "started": _time(sidecar.get("started")),
                "ended": _time(sidecar.get("ended"), sidecar.get("started")),
                "trials": _count(sidecar.get("trials")),
                "runs": len(runs),
                "simulated": "yes" if sidecar.get("simulated") else "no",
                "host": ", ".join(sorted({str(r.get("host")) for r in runs if r.get("host")}))
                or "—",
                "protocol": _hash(sidecar.get("protocol_sha256"), protocol_sha256),
                "stimulus set": _hash(sidecar.get("stimulus_set_manifest_sha256"), stimuli_sha256),
                "calibration": f"{calibration.get('status', '—')}"
                + (
                    f" {calibration['readings_sha256'][:12]}"
                    if calibration.get("readings_sha256")
                    else ""
                ),
                "glarelab": packages.get("glarelab", "—"),
            }
        )
    return rows
