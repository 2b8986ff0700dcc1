"""glarelab bench's spectral section: the colour methods against one FFT per wavelength."""

from glarelab.bench.spectral import spectral_bench


def test_spectral_section_compares_with_one_fft_per_wavelength():
    rows = spectral_bench((65, 65), pixel_deg=0.02)
    by_variant = {r["variant"].split(":")[0].split(" (")[0]: r for r in rows}
    assert by_variant["reference"]["delta_e_mean"] == 0.0
    assert by_variant["scaled copies of one FFT"]["delta_e_mean"] < 1e-6  # exact copies
    assert by_variant["Kakimoto"]["delta_e_mean"] > 0.5  # three wavelengths are visibly off
