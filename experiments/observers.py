"""Simulated observers: a documented model of brightness perception that answers every protocol.

They drive the same engines a lab session does, key by key, so their data take exactly the
path a participant's take. Each observer has its own seeded generator; each trial draws its
noise from a generator fixed by (observer, trial), so a resumed session answers exactly as an
uninterrupted one.

**Brightness of glare.** A reference whose disk (or source) is shown at ``L`` with glare
strength ``x`` looks as bright as ``L × (1 + g · B · (1 - exp(-x / x0)))``: the boost rises
with the glare and saturates (Yoshida §5: "this effect saturates for large values of L_disk"),
``B`` is the largest boost, ``x0`` the saturation strength and ``g ~ N(1, observer_sd)`` the
observer's own gain (clipped at 0). For Yoshida 2008, ``x = (L_disk - L_dmax) / L_dmax``; for
Spencer 1995, ``x`` is the source's excess over the displayed peak.

**Yoshida 2008**: the observer sets the left target to ``P (1 - margin)`` and the right to
``P (1 + margin)``, each with multiplicative noise ``N(0, setting_sd)``, using coarse then fine
key presses; answers Q1 (glow) yes when the boost exceeds 3 %, Q2 (ring) yes with probability
rising with the level, Q3 (same size) yes for the lowest two levels.

**Spencer 1995**: compares the perceived glare image (``0.75 × P`` of the maximum) with the
disc plus noise ``N(0, noise_sd)``; answers 'neither' when they differ by less than
``neither_band``. The context multiplies the boost by ``context_gain``.

**Luidolt 2020**: rates each category ``round(N(mean, sd))`` within the scale.
"""

from __future__ import annotations

import math

import numpy as np

from .engine import participant_rng

__all__ = ["SimulatedObserver"]


class SimulatedObserver:
    """An observer for a protocol; ``keys(screen)`` returns the key presses (with times)."""

    def __init__(self, protocol, participant: str, *, seed: int = 0):
        self.protocol = protocol
        self.participant = participant
        self.seed = seed
        self.params = protocol["observer"]
        rng = participant_rng(protocol.seed, participant, f"observer {seed}")
        sd = self.params.get("observer_sd", 0.0)
        self.gain = max(0.0, float(rng.normal(1.0, sd)))

    def _trial_rng(self, trial: int) -> np.random.Generator:
        return participant_rng(
            self.protocol.seed, self.participant, f"observer {self.seed} trial {trial}"
        )

    def _boost(self, strength: float, largest: float, saturation: float) -> float:
        return self.gain * largest * (1.0 - math.exp(-max(strength, 0.0) / saturation))

    def keys(self, screen: dict) -> list[tuple[str, float]]:
        kind = screen["kind"]
        if kind == "instructions":
            return [("space", 1.0)]
        study = self.protocol.study
        if study == "yoshida2008":
            return self._yoshida(screen)
        if study == "spencer1995":
            return self._spencer(screen)
        if study == "luidolt2020":
            return self._luidolt(screen)
        raise ValueError(f"no simulated observer for study {study!r}")

    # --- Yoshida 2008 ---------------------------------------------------------------------

    def _yoshida_trial(self, screen: dict) -> dict:
        g, p = self.protocol["glare"], self.params
        _, method, label = screen["reference"].split("_")
        index = g[method]["labels"].index(label)
        level = g[method]["levels_cd_m2"][index]
        l_dmax = g["l_dmax_cd_m2"]
        largest = p["boost_gaussian"] if method == "gaussian" else p["boost_vos"]
        boost = self._boost((level - l_dmax) / l_dmax, largest, p["saturation"])
        return {"index": index, "boost": boost, "perceived": min(level, l_dmax) * (1 + boost)}

    def _yoshida(self, screen: dict) -> list[tuple[str, float]]:
        trial = self._yoshida_trial(screen)
        rng = self._trial_rng(screen["trial"])
        if screen["kind"] == "adjust":
            p, t = self.params, self.protocol["trials"]
            wanted = {
                "left": trial["perceived"]
                * (1 - p["margin"])
                * (1 + rng.normal(0, p["setting_sd"])),
                "right": trial["perceived"]
                * (1 + p["margin"])
                * (1 + rng.normal(0, p["setting_sd"])),
            }
            start = {"left": screen["left_cd_m2"], "right": screen["right_cd_m2"]}
            keys: list[tuple[str, float]] = []
            clock = 0.0
            for side in ("left", "right"):
                clock += 0.5
                keys.append((side, clock))
                change = wanted[side] - start[side]
                coarse = int(abs(change) // t["coarse_step_cd_m2"])
                rest = abs(change) - coarse * t["coarse_step_cd_m2"]
                fine = round(rest / t["fine_step_cd_m2"])
                up = change > 0
                for _ in range(coarse):
                    clock += 0.15
                    keys.append(("up" if up else "down", clock))
                for _ in range(fine):
                    clock += 0.25
                    keys.append(("pageup" if up else "pagedown", clock))
            keys.append(("return", clock + 1.0 + float(rng.exponential(2.0))))
            return keys
        if screen["kind"] == "question":
            number = screen["number"]
            if number == 1:
                answer = trial["boost"] > 0.03
            elif number == 2:
                answer = rng.random() < trial["index"] / 6
            else:
                answer = trial["index"] <= 1
            return [("y" if answer else "n", 1.0 + 0.1 * number)]
        return []

    # --- Spencer 1995 ---------------------------------------------------------------------

    def _spencer(self, screen: dict) -> list[tuple[str, float]]:
        if screen["kind"] != "present":
            return []
        p = self.params
        rng = self._trial_rng(screen["trial"])
        level = int(screen["glare_image"].rsplit("_", 1)[1])
        strength = self.protocol["glare"]["strengths"][level - 1]
        largest = p["boost"] * (p["context_gain"] if screen["context"] == "lamp" else 1.0)
        peak = self.protocol["glare"]["peak_fraction"]
        perceived_glare = peak * (1 + self._boost(strength, largest, p["saturation"]))
        difference = perceived_glare - screen["disc_fraction"] + rng.normal(0, p["noise_sd"])
        if abs(difference) < p["neither_band"]:
            key = "down"
        elif difference > 0:
            key = screen["glare_side"]
        else:
            key = "left" if screen["glare_side"] == "right" else "right"
        return [(key, 0.6 + float(rng.exponential(0.4)))]

    # --- Luidolt 2020 ---------------------------------------------------------------------

    def _luidolt(self, screen: dict) -> list[tuple[str, float]]:
        q = self.protocol["questionnaire"]
        rng = self._trial_rng(screen["trial"])
        if screen["kind"] == "rate":
            mean = self.params["means"][screen["trial"] - 1]
            rating = int(
                np.clip(round(rng.normal(mean, self.params["sd"])), q["scale_min"], q["scale_max"])
            )
            return [(str(rating), 5.0 + float(rng.exponential(5.0)))]
        if screen["kind"] == "comment":
            return [("return", 1.0)]
        return []
