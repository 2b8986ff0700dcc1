"""A kernel as a figure for print: axes in degrees of visual angle, the intensity scale's ticks
at the codes the kernel image gives those intensities, PNG and PDF; ``glarelab psf`` and
``glarelab gallery`` write it beside each kernel image."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from glarelab.cli import main
from glarelab.glare.models.wave import sigmoid_Kakimoto2004
from glarelab.stimuli.preview import psf_figure, psf_to_display


def test_the_scales_ticks_are_the_codes_of_those_intensities():
    # a kernel whose pixels are 10^-6 … 10^-4 of its peak: each shows with its tick's code
    decades = np.array([-6.0, -5.0, -4.0])
    values = np.concatenate([[1.0], 10.0**decades]).reshape(2, 2)
    codes = psf_to_display(values)
    expected = np.round(sigmoid_Kakimoto2004(10.0**decades * 1e6))
    np.testing.assert_array_equal(codes.ravel()[1:], expected)
    assert codes.ravel()[0] == 255  # the clipped centre


def test_a_bad_pixel_size_is_refused(tmp_path):
    with pytest.raises(ValueError, match="pixel_deg must be a positive number"):
        psf_figure(tmp_path / "k.png", np.ones((3, 3)), pixel_deg=0)


def test_psf_and_gallery_write_the_figure_beside_the_image(tmp_path):
    out = tmp_path / "psf.png"
    assert main(["psf", "--out", str(out), "--size", "31", "--model", "gaussian"]) == 0
    assert Image.open(out).size == (31, 31)  # the kernel image, pixel for pixel, as before
    figure = tmp_path / "psf_axes.png"
    assert Image.open(figure).size[0] > 300  # a figure with axes and a colour bar
    assert (tmp_path / "psf_axes.pdf").read_bytes().startswith(b"%PDF")
    gallery = tmp_path / "gallery"
    assert main(["gallery", "--out", str(gallery), "--pixel-deg", "0.05", "--size", "21"]) == 0
    tiles = sorted(p for p in gallery.glob("*.png") if not p.stem.endswith("_axes"))
    assert tiles
    for tile in tiles:
        assert (gallery / f"{tile.stem}_axes.png").is_file(), tile.name
        assert (gallery / f"{tile.stem}_axes.pdf").is_file(), tile.name
