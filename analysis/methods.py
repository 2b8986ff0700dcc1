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
    """Hashes and versions behind the data: protocol, stimulus-set manifest, calibration."""
    first = next(iter(sidecars.values()), {})
    protocols = {s.get("protocol_sha256") for s in sidecars.values()}
    record = {
        "protocol_sha256": protocol_sha256,
        "protocol_sha256_in_sessions": sorted(p for p in protocols if p),
        "calibration": first.get("calibration"),
        "images_encoded_with": first.get("images_encoded_with"),
        "packages": first.get("packages"),
        "simulated": first.get("simulated"),
    }
    if stimuli is not None:
        manifest = Path(stimuli) / "manifest.json"
        data = json.loads(manifest.read_text())
        record["stimulus_set_manifest_sha256"] = hashlib.sha256(manifest.read_bytes()).hexdigest()
        record["stimulus_set_calibration_sha256"] = data.get("calibration_sha256")
        record["stimulus_set_calibration_status"] = data.get("calibration", {}).get("status")
    return record
