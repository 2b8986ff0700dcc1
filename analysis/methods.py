"""What every methods paragraph and report shares: the display as the text names it, and the
data's provenance."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

__all__ = ["display_text", "provenance"]


def display_text(protocol) -> str:
    """The display and viewing conditions, as the methods section names them."""
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
    ``"mixed"`` otherwise (``sessions`` says which)."""
    sessions = [
        {
            "file": Path(name).name,
            "participant": s.get("participant"),
            "session": s.get("session"),
            "status": s.get("status"),
            "simulated": bool(s.get("simulated")),
            "protocol_sha256": s.get("protocol_sha256"),
            "calibration": s.get("calibration"),
            "images_encoded_with": s.get("images_encoded_with"),
            "glarelab": (s.get("packages") or {}).get("glarelab"),
        }
        for name, s in sidecars.items()
    ]
    flags = {s["simulated"] for s in sessions}
    simulated = (flags == {True}) if len(flags) < 2 else "mixed"
    calibrations = {json.dumps(s["calibration"], sort_keys=True, default=str) for s in sessions}
    record = {
        "protocol_sha256": protocol_sha256,
        "protocol_sha256_in_sessions": sorted({s["protocol_sha256"] for s in sessions} - {None}),
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
        data = json.loads(manifest.read_text())
        record["stimulus_set_manifest_sha256"] = hashlib.sha256(manifest.read_bytes()).hexdigest()
        record["stimulus_set_calibration_sha256"] = data.get("calibration_sha256")
        record["stimulus_set_calibration_status"] = data.get("calibration", {}).get("status")
    return record
