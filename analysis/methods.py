"""A methods paragraph written from the protocol that was run, and the data's provenance."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

__all__ = ["methods_paragraph", "provenance"]


def _levels(values) -> str:
    return ", ".join(f"{v:g}" for v in values)


def methods_paragraph(study: str, protocol: dict, participants: int, simulated: bool) -> str:
    """Methods text naming the protocol's actual parameters."""
    who = f"{participants} {'simulated observers' if simulated else 'participants'}"
    if study == "luidolt2020":
        q = protocol["questionnaire"]
        return (
            f"{who} rated {len(q['categories'])} categories ({', '.join(q['categories'])}) on a "
            f"{q['scale_min']}-{q['scale_max']} Likert scale from “{q['anchors'][0]}” to "
            f"“{q['anchors'][1]}”{', each with an optional comment' if q['comments'] else ''}."
        )
    d, v = protocol["display"], protocol["viewing"]
    size = (
        f"{d['diagonal_in']:g}-inch"
        if d["diagonal_in"] is not None
        else f"{d['pixel_pitch_mm']:g} mm pixel pitch"
    )
    display = (
        f"a {d['name']} ({size}, {d['resolution_px'][0]} × {d['resolution_px'][1]} px, "
        f"{d['bit_depth']}-bit, maximum {d['max_cd_m2']:g} cd/m²) viewed from "
        f"{v['distance_m']:g} m in {v['room_lux']:g} lx"
    )
    if study == "yoshida2008":
        s, g = protocol["stimulus"], protocol["glare"]
        return (
            f"{who} matched the brightness of a {s['disk_deg']:g}° disk on a {s['background_deg']:g}° "
            f"cloudy sky (mean {s['background_mean_cd_m2']:g} cd/m²) shown on {display}. Glare was "
            f"added above L_dmax = {g['l_dmax_cd_m2']:g} cd/m² with a Gaussian kernel (σ = "
            f"{g['gaussian']['sigma_deg']:g}°; levels {'-'.join(g['gaussian']['labels'][::5])}: "
            f"{_levels(g['gaussian']['levels_cd_m2'])} cd/m²) and with the Vos PSF "
            f"({g['vos']['regime']}; levels {'-'.join(g['vos']['labels'][::5])}: "
            f"{_levels(g['vos']['levels_cd_m2'])} cd/m²), rendered at {s['supersample']}× resolution. "
            f"The darker and brighter targets started at {_levels(s['target_start_cd_m2'])} cd/m²; "
            f"{protocol['trials']['training_trials']} training trials preceded the 12 references, "
            f"shown once each in {protocol['trials']['order']} order."
        )
    s, g, t = protocol["stimulus"], protocol["glare"], protocol["trials"]
    return (
        f"{who} compared a light source with glare (Vos PSF, {g['regime']}"
        f"{', with flare lines' if g['flare_lines'] else ''}; peak {100 * g['peak_fraction']:g} % of "
        f"the maximum; {len(g['strengths'])} strengths from {g['strengths'][0]:g} to "
        f"{g['strengths'][-1]:g}) with a disc and an annulus at {s['annulus_ratio']:.3g} of its "
        f"intensity, in {s['window_px']} × {s['window_px']} px windows on {display}, shown for "
        f"{' or '.join(f'{x:g}' for x in t['presentation_ms'])} ms, in contexts "
        f"{', '.join(s['context'])}. Interleaved staircases ({t['reversals']} reversals, steps "
        f"{_levels(t['step_fractions'])} of the maximum; 'neither': {t['neither']}) set the disc."
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
