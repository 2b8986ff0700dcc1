"""Diffraction and scattering together: :class:`HybridGlare` (Kakimoto et al. 2004 §2.1 with
the Vos PSF of Spencer et al. 1995)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from glarelab.glare.models.base import GlareModel
from glarelab.glare.models.digitise import Kernel
from glarelab.glare.models.eye import Regime
from glarelab.glare.models.spencer1995 import VosGlare, _combine
from glarelab.glare.models.wave import WaveOpticsGlare

__all__ = ["HybridGlare"]


@dataclass(frozen=True)
class HybridGlare(GlareModel):
    """Diffraction and scattering together: the Vos PSF with its unscattered core ``f0``
    replaced by a wave-optics diffraction kernel.

    Kakimoto et al. (2004, §2.1) note that diffraction alone misses the scattering in the eye
    and that a hybrid with Spencer et al.'s filter may be needed. In the Vos PSF the narrow
    Gaussian ``f0`` stands for the unscattered (diffraction-limited) light; here that share,
    ``w0``, is spread by the diffraction pattern of the pupil, lids, lashes and particles, and
    the scattering terms ``w1 f1 + w2 f2`` (and the halo ``w3 f3``) are the Vos ones.

    Parameters
    ----------
    wave
        The diffraction model.
    regime, age, flare_lines, seed
        As for :class:`VosGlare`.

    References
    ----------
    Kakimoto et al. 2004, §2.1; Spencer et al. 1995, eqs. 5, 8-10.

    Examples
    --------
    >>> m = HybridGlare(WaveOpticsGlare(pupil_mm=3.0, eyelashes=False, eyelid=False,
    ...                                 particles=0))
    >>> k = m.kernel(0.05, (41, 41))
    >>> bool(abs(k.values.sum() + k.energy_outside - 1) < 1e-9)
    True
    """

    wave: WaveOpticsGlare = field(default_factory=WaveOpticsGlare)
    regime: Regime = "photopic"
    age: float | None = None
    flare_lines: bool = False
    seed: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.wave, WaveOpticsGlare):
            raise ValueError(f"wave must be a WaveOpticsGlare, got {self.wave!r}")
        VosGlare(regime=self.regime, age=self.age, flare_lines=self.flare_lines, seed=self.seed)

    def _vos(self) -> VosGlare:
        # one eye: the halo needs a 3 mm pupil (the photopic PSF has no halo, and no pupil)
        return VosGlare(
            regime=self.regime,
            age=self.age,
            flare_lines=self.flare_lines,
            seed=self.seed,
        ).with_eye_state(pupil_mm=self.wave.pupil_diameter)

    def halo(self) -> str:
        return self._vos().halo()

    def check_kernel(
        self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False
    ) -> None:
        """Refuse a kernel either part would refuse (:meth:`GlareModel.check_kernel`).

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether the colour kernel would be made; default False.

        Raises
        ------
        ValueError
            If the wave-optics or the Vos part would refuse this size.
        """
        self.wave.check_kernel(pixel_deg, shape, colour=colour)
        self._vos().check_kernel(pixel_deg, shape, colour=colour)

    def description(self, colour: bool) -> dict:
        """The model's name and parameters, for logs.

        Parameters
        ----------
        colour
            Whether the kernel described is the colour one (recorded as ``colour``).

        Returns
        -------
        dict
            The Vos part's description (:meth:`VosGlare.description`), named ``HybridGlare``.
        """
        return {**self._vos().description(colour), "model": "HybridGlare"}

    def kernel(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> Kernel:
        """The kernel: the Vos PSF with its unscattered core replaced by the wave-optics
        diffraction kernel (class docstring).

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether a kernel per colour channel ``(KH, KW, C)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False.

        Returns
        -------
        Kernel
            The kernel, each channel summing to its PSF energy inside the support, with its
            energy account.
        """
        vos_model = self._vos()
        parts = vos_model.parts(pixel_deg, shape, colour=colour)
        diffraction = self.wave.kernel(pixel_deg, shape, colour=colour)
        w0 = parts["weights"][0]
        core = diffraction.values if not colour else np.moveaxis(diffraction.values, -1, 0)
        description = {
            **vos_model.description(colour),
            "model": "HybridGlare",
            "wave": diffraction.description,
            # the light the kernel books: the core's share of it is the wave model's
            "admitted_share": 1.0 - w0 * (1.0 - diffraction.description["admitted_share"]),
        }
        return _combine(
            w0 * core,
            w0 * np.asarray(diffraction.energy_outside),
            parts,
            pixel_deg=pixel_deg,
            colour=colour,
            description=description,
        )
