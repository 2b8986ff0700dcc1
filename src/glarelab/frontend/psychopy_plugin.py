"""A stimulus set's images in a lab's own PsychoPy experiment, code for code, at any bit depth.

An 8-bit set's ``NAME.png`` is an 8-bit PNG of the display codes: PsychoPy's own
``visual.ImageStim(win, image="NAME.png")`` (and Builder's Image component) shows it as it is,
and nothing here is needed. A set for a 10-bit (or deeper) display keeps its codes in
``NAME_10bit.png``, a 16-bit PNG that PsychoPy's ImageStim cannot show (Pillow opens it as
``I;16``, which PsychoPy clips to black and white). :class:`SetImageStim` is PsychoPy's
ImageStim for such a file: it reads the codes exactly
(:func:`glarelab.stimuli.stimulus_set.read_png_codes`), rounds them to the window's bits
(:func:`glarelab.frontend.images.codes_at_bits`), uploads them as a float texture, draws them
pixel for pixel (``units='pix'``, no interpolation) and puts the image's edges on whole
pixels, as a glarelab session draws the set. On a window of ``bpc=(10, 10, 10)`` on a 10-bit
display, each image pixel is the display's code.

glarelab registers the class as a PsychoPy plugin (the ``psychopy.visual`` entry point in its
``pyproject.toml``): once PsychoPy has loaded the plugin (``psychopy.plugins.loadPlugin(
"glarelab")``, or the Plugins dialog's "load at start-up") it is ``visual.SetImageStim``;
without the plugin it is imported from here. The Builder component that writes it is
:class:`glarelab.frontend.psychopy_builder.SetImageComponent`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from psychopy import visual

from glarelab.experiments.layout import Placement
from glarelab.frontend.images import codes_at_bits
from glarelab.frontend.window import window_bits
from glarelab.stimuli.stimulus_set import MANIFEST, codes_png, read_png_codes

__all__ = ["SetImageStim", "set_image_codes"]


def set_image_codes(image: str | Path) -> tuple[np.ndarray, int]:
    """The display codes of a set's image and their bit depth, from the file that holds them
    exactly: ``image`` is a set's ``NAME.png`` (for a deeper display its ``NAME_<bits>bit.png``
    beside it is read, as the set's manifest names it) or a codes PNG itself.

    Parameters
    ----------
    image
        A set's ``NAME.png`` (its manifest beside it gives the set's bit depth, 8, 10, 12 or
        16) or a codes PNG, ``NAME_<bits>bit.png``.

    Returns
    -------
    codes : numpy.ndarray
        The integer display codes, ``(H, W)`` or ``(H, W, 3)``, in 0 … 2^bits − 1.
    bits : int
        Their bit depth.

    Raises
    ------
    FileNotFoundError
        For an image that is not there (or a deeper set's codes file missing).
    ValueError
        For a PNG that holds no display codes.
    """
    path = Path(image)
    if not path.is_file():
        raise FileNotFoundError(f"image: {str(image)!r} is not a file")
    manifest = path.parent / MANIFEST
    if manifest.is_file() and path.suffix == ".png":
        from glarelab.files.inputs import loads_json

        data = loads_json(manifest.read_text(encoding="utf-8"), source=manifest)
        bits = int(data.get("calibration", {}).get("bit_depth", 8))
        if path.stem in data.get("images", {}) and bits > 8:
            path = path.with_name(codes_png(path.stem, bits))
            if not path.is_file():
                raise FileNotFoundError(
                    f"image: the set's {bits}-bit codes {path.name} are missing beside "
                    f"{Path(image).name} (run glarelab stimuli verify on {path.parent})"
                )
    return read_png_codes(path)


class SetImageStim(visual.ImageStim):
    """PsychoPy's ``ImageStim`` for a glarelab set's image, shown code for code.

    Parameters
    ----------
    win
        The PsychoPy window; for a 10-bit set, opened with ``bpc=(10, 10, 10)`` on a 10-bit
        display (an 8-bit window shows the nearest 8-bit codes).
    image
        The set's ``NAME.png`` (or ``NAME_<bits>bit.png``); None: black 2 × 2 pixels until
        :meth:`setImage`.
    pos
        The image's centre in pixels from the window's centre; it is moved by less than a pixel
        so that the image's edges lie on whole pixels (``snap=False`` keeps it as given).
    snap
        Put the edges on whole pixels (default): an odd-sized image at a whole-pixel centre of
        an even-sized window has its edges on half pixels, and the nearest-texel lookup
        doubles some rows and columns and drops others.
    units : {"pix"}
        The only units a set's image can be shown in, one image pixel on one screen pixel
        (default); anything else raises.
    size
        None (default): the image's own size; else ``(width, height)``, px, which must be the
        image's own.
    **kwargs
        Anything else PsychoPy's ``ImageStim`` takes (``name``, ``ori``, ``opacity``,
        ``depth``, ``autoLog``); not ``interpolate``, ``colorSpace``, ``color``, ``mask``,
        ``flipHoriz`` or ``flipVert``, which are fixed (the codes are drawn as they are).

    Raises
    ------
    ValueError
        For ``units`` other than ``'pix'``, a ``size`` other than the image's, or a PNG
        without display codes.

    Notes
    -----
    The codes ``c`` of a ``b``-bit set are shown on a ``w``-bit window as
    ``round(c × (2^w − 1) / (2^b − 1))`` (the same codes when ``w = b``), uploaded as the
    float texture values PsychoPy maps linearly onto the frame buffer (``2 v − 1`` for a grey
    image, ``v`` for a colour one, ``v = code / (2^w − 1)``).

    Examples
    --------
    In a Coder script (or a Builder Code component)::

        from psychopy import visual
        from glarelab.frontend.psychopy_plugin import SetImageStim

        win = visual.Window(fullscr=True, bpc=(10, 10, 10), color=-1, units="pix")
        stim = SetImageStim(win, image="sets/yoshida2008/reference_vos_f.png")
        stim.draw()
        win.flip()
    """

    def __init__(
        self,
        win,
        image: str | Path | None,
        *,
        pos: tuple[float, float] = (0.0, 0.0),
        snap: bool = True,
        units: str = "pix",
        size=None,
        **kwargs,
    ):
        if units != "pix":
            raise ValueError(
                f"units must be 'pix' (one image pixel on one screen pixel); got {units!r}"
            )
        for fixed in ("interpolate", "colorSpace", "color", "mask", "flipHoriz", "flipVert"):
            if fixed in kwargs:
                raise ValueError(
                    f"{fixed} is fixed by SetImageStim (the codes are drawn as they are); "
                    f"got {fixed}={kwargs[fixed]!r}"
                )
        self.snap = snap
        levels, shape = self._levels(win, image)
        if size is not None and tuple(float(v) for v in size) != (shape[1], shape[0]):
            raise ValueError(
                f"size must be None, the image's own ({shape[1]}, {shape[0]}) pixels; got {size!r}"
            )
        self.codes_file = image
        super().__init__(
            win,
            image=levels,
            units="pix",
            size=(shape[1], shape[0]),
            pos=self._snapped(win, pos, shape),
            interpolate=False,
            colorSpace="rgb",
            **kwargs,
        )

    @staticmethod
    def _levels(win, image) -> tuple[np.ndarray, tuple[int, ...]]:
        """The float texture of ``image``'s codes at ``win``'s bits, rows bottom-up (black
        2 × 2 pixels for None: a Builder image set as its routine starts)."""
        if image is None:
            return np.full((2, 2), -1.0, np.float32), (2, 2)
        codes, bits = set_image_codes(image)
        win._setCurrent()  # the window whose frame buffer's bits are read
        bits_shown = window_bits()
        fraction = codes_at_bits(codes, bits, bits_shown) / (2**bits_shown - 1)
        level = fraction if fraction.ndim == 3 else fraction * 2.0 - 1.0
        return np.flipud(level).astype(np.float32), codes.shape

    def _snapped(self, win, pos, shape) -> tuple[float, float]:
        if not self.snap:
            return (float(pos[0]), float(pos[1]))
        width, height = (int(v) for v in win.size)
        left = int(np.floor(width / 2 + float(pos[0]) - shape[1] / 2 + 0.5))
        bottom = int(np.floor(height / 2 + float(pos[1]) - shape[0] / 2 + 0.5))
        return Placement(left, bottom, shape[1], shape[0], (width, height)).pos

    def setImage(self, value, log=None):
        """Show another image of a set (Builder's "set every repeat"); an array is taken as
        PsychoPy's texture values, as ``ImageStim`` takes it.

        Parameters
        ----------
        value : str, pathlib.Path or numpy.ndarray
            A set's ``NAME.png`` or a codes PNG (as ``image`` of the constructor): the size
            becomes the new image's and the position is snapped again; or an array of
            texture values, -1 … 1 (grey) or 0 … 1 (colour), set as it is.
        log : bool, optional
            Whether PsychoPy logs the change (None: the stimulus's ``autoLog``).
        """
        if isinstance(value, np.ndarray):  # ImageStim's own call, from __init__
            super().setImage(value, log=log)
            return
        levels, shape = self._levels(self.win, value)
        self.codes_file = value
        super().setImage(levels, log=log)
        self.size = (shape[1], shape[0])
        self.pos = self._snapped(self.win, self.pos, shape)
