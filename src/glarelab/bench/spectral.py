"""The spectral section of the benchmark: the wave-optics PSF's colour methods against one FFT
per wavelength, in time and CIEDE2000."""

from __future__ import annotations

from glarelab import glare
from glarelab.bench.timing import timed

__all__ = ["spectral_bench"]


def spectral_bench(
    shape: tuple[int, int] = (1025, 1025), *, pixel_deg: float = 0.004, repeats: int = 1
) -> list[dict]:
    """Wave-optics PSF (6 mm eye, lashes, lid, particles) as an RGB kernel: one FFT per
    wavelength (the reference, 61 wavelengths) against exactly rescaled copies of one FFT,
    Kakimoto's three wavelengths, and fewer wavelengths; time and CIEDE2000 against the
    reference (:func:`glarelab.glare.models.wave.kernel_colour_error`). The kernels are FFT samples
    rebinned (``pixel_integration='rebin'``), the path whose cost these methods differ in: with
    exact pixel integration one autocorrelation serves every wavelength
    (docs/speed-accuracy.md).

    Parameters
    ----------
    shape
        The kernel's odd shape, pixels; default ``(1025, 1025)``.
    pixel_deg
        Visual angle of one pixel, degrees; default 0.004.
    repeats
        Rounds of the variants, the fastest time kept; default 1.

    Returns
    -------
    list of dict
        One row per variant: ``workload``, ``variant``, ``seconds``, the colour error of
        :func:`glarelab.glare.models.wave.kernel_colour_error` and ``speed_vs_peer`` (the
        reference's time over this one's).
    """

    def kernel(**options):
        model = glare.WaveOpticsGlare(pupil_mm=6.0, pixel_integration="rebin", **options)
        return lambda: model.kernel(pixel_deg, shape, colour=True).values

    variants = {
        "reference: one FFT per wavelength (61)": kernel(spectral="reference"),
        "scaled copies of one FFT (61)": kernel(spectral="scaled"),
        "scaled copies, 31 wavelengths": kernel(
            spectral="scaled", spectrum=glare.Spectrum(n_wavelengths=31)
        ),
        "Kakimoto: three wavelengths": kernel(spectral="kakimoto"),
    }
    results, reference = [], None
    for label, (seconds, rgb) in timed(variants, repeats).items():
        reference = rgb if reference is None else reference
        error = glare.wave.kernel_colour_error(reference, rgb, "ITU-R BT.709")
        results.append(
            {"workload": f"wave-optics PSF {shape[0]}²", "variant": label, "seconds": seconds}
            | error
        )
    base = results[0]["seconds"]
    for r in results:
        r["speed_vs_peer"] = base / r["seconds"]
    return results
