"""A session's images on the screen, code for code, and the proof read back from the frame buffer.

Luminance images (cd/m²) from the stimulus set are turned into display codes through the
calibration (the set's own when the session runs uncalibrated), rounded to the window's bits
here (not by the graphics card), and drawn pixel for pixel (``units='pix'``, no interpolation,
rows flipped to PsychoPy's bottom-up order) with every edge on a whole screen pixel
(:mod:`glarelab.experiments.layout`), so each image pixel is one screen pixel for odd and even
sizes alike; :meth:`ImageBank.check_presentation` reads a screen's images back from the frame
buffer to prove it. Every image is encoded and uploaded once: the set's images when first
needed, an image that depends on a setting (a target, a comparison) when it changes.
"""

from __future__ import annotations

import numpy as np

from glarelab.display.calibration import Calibration, synthetic_calibration
from glarelab.display.checks import ScreenFacts
from glarelab.experiments.layout import Placement, row_layout
from glarelab.frontend.window import read_framebuffer_codes
from glarelab.stimuli.stimulus_set import StimulusSet, codes_png, read_png_codes

__all__ = ["ImageBank", "codes_at_bits"]


def codes_at_bits(codes: np.ndarray, bits: int, window_bits: int) -> np.ndarray:
    """``bits``-bit codes as the nearest codes of a ``window_bits``-bit window:
    ``round(code × (2^window_bits − 1) / (2^bits − 1))``; the same codes when the bits agree.

    Parameters
    ----------
    codes
        Integer codes at ``bits``.
    bits
        Their bit depth.
    window_bits
        The window's bits per channel.

    Returns
    -------
    numpy.ndarray
        The codes at ``window_bits``.

    Examples
    --------
    >>> codes_at_bits(np.array([0, 43, 255]), 8, 10).tolist()
    [0, 173, 1023]
    >>> codes_at_bits(np.array([0, 2, 1023]), 10, 8).tolist()
    [0, 0, 255]
    """
    codes = np.asarray(codes)
    if bits == window_bits:
        return codes.astype(np.int64)
    return np.rint(codes * ((2**window_bits - 1) / (2**bits - 1))).astype(np.int64)


def _box(placement: Placement) -> tuple[int, int, int, int]:
    return placement.left_px, placement.bottom_px, placement.width_px, placement.height_px


class ImageBank:
    """The PsychoPy stimuli of a session's images, encoded and uploaded once each.

    Parameters
    ----------
    stimulus_set
        The session's stimulus set; None for a study without images.
    calibration
        The display calibration; None: the protocol display's synthetic one, made when the
        first image is encoded.
    display
        The protocol's ``[display]`` table (None for a protocol without one).
    display_bits
        Bits per channel of the protocol's display.
    """

    def __init__(
        self,
        stimulus_set: StimulusSet | None,
        calibration: Calibration | None,
        *,
        display: dict | None,
        display_bits: int,
    ):
        self.set = stimulus_set
        self.calibration = calibration
        self.display = display
        self.display_bits = display_bits
        self.window = None
        self.facts: ScreenFacts | None = None
        self._stims: dict[tuple, object] = {}  # set images by their terms
        self._roles: dict[str, tuple[tuple, object]] = {}  # images that change: by role

    def attach(self, window, facts: ScreenFacts) -> None:
        """Draw into ``window``, whose measured facts give its bits.

        Parameters
        ----------
        window
            The open PsychoPy window.
        facts : glarelab.display.checks.ScreenFacts
            What the window measured (its bits per channel).
        """
        self.window = window
        self.facts = facts

    @property
    def window_bits(self) -> int:
        """Bits per channel of the open window (the calibration's before it opens)."""
        if self.facts is not None:
            return self.facts.bits_per_channel
        return self.calibration.bit_depth if self.calibration else self.display_bits

    # --- encoding -----------------------------------------------------------------------------

    def codes(self, luminance: np.ndarray) -> np.ndarray:
        """The codes the window shows for ``luminance`` (cd/m²): the calibration's, rounded to
        the window's bits here (:func:`codes_at_bits`), not by the graphics card, which
        rounds a value near a tie either way.

        Parameters
        ----------
        luminance
            The image, cd/m², ``(H, W)`` or ``(H, W, 3)``, top row first.

        Returns
        -------
        numpy.ndarray
            Integer codes at the window's bits, the shape of ``luminance``.
        """
        if self.calibration is None:
            self.calibration = synthetic_calibration(
                max_cd_m2=self.display["max_cd_m2"],
                black_cd_m2=self.display["black_cd_m2"],
                bit_depth=self.display_bits,
            )
        codes, _ = self.calibration.encode(luminance)
        return codes_at_bits(codes, self.calibration.bit_depth, self.window_bits)

    def levels(self, luminance: np.ndarray) -> np.ndarray:
        """The array an ``ImageStim`` shows as ``luminance``'s codes, rows bottom-up.

        PsychoPy maps the two kinds of array differently: a grey (H, W) array is a luminance
        texture in [−1, 1], shown as ``(v + 1) / 2``; a colour (H, W, 3) array is an RGB float
        texture shown as it is, clamped to [0, 1]. Each gets the values that its path maps
        linearly onto the codes (a colour frame passed as [−1, 1] would show every code below
        mid-range as black).

        Parameters
        ----------
        luminance
            The image, cd/m², ``(H, W)`` or ``(H, W, 3)``, top row first.

        Returns
        -------
        numpy.ndarray
            Floats: in [−1, 1] for grey, [0, 1] for colour, rows bottom-up.
        """
        fraction = self.codes(luminance).astype(np.float64) / (2**self.window_bits - 1)
        level = fraction if fraction.ndim == 3 else fraction * 2.0 - 1.0
        return np.flipud(level)

    def image_stim(self, luminance: np.ndarray):
        """An ``ImageStim`` showing ``luminance`` pixel for pixel.

        Parameters
        ----------
        luminance
            The image, cd/m², ``(H, W)`` or ``(H, W, 3)``, top row first.

        Returns
        -------
        psychopy.visual.ImageStim
            The stimulus, one image pixel per screen pixel.
        """
        from psychopy import visual

        levels = self.levels(luminance)  # (H, W), or (H, W, 3) for a colour image
        h, w = levels.shape[:2]
        return visual.ImageStim(
            self.window,
            image=levels,
            size=(w, h),
            units="pix",
            interpolate=False,
            colorSpace="rgb",
            autoLog=False,
        )

    # --- the stimuli of screens ---------------------------------------------------------------

    def stim(self, image: dict):
        """The stimulus of a screen's image, encoded and uploaded once: a set image on first
        use, an image that depends on a setting (a target, a comparison) when it changes.

        Parameters
        ----------
        image
            A screen's image: its ``terms`` (``[(name, weight)]`` of the set's images) and
            ``role``.

        Returns
        -------
        psychopy.visual.ImageStim
            The stimulus.
        """
        terms = tuple((name, float(weight)) for name, weight in image["terms"])
        role = image["role"]
        if len(terms) == 1 and terms[0][1] == 1.0:  # a set image as it is
            if terms not in self._stims:
                self._stims[terms] = self.image_stim(self.set.image(terms[0][0]))
            return self._stims[terms]
        shown, stim = self._roles.get(role, (None, None))
        if shown != terms:
            luminance = self.set.compose(terms)
            if stim is None:
                stim = self.image_stim(luminance)
            else:
                stim.image = self.levels(luminance)
            self._roles[role] = (terms, stim)
        return stim

    def frame_stims(self, step: dict) -> list:
        """A sequence frame's images, centred, uploaded now and not cached.

        Parameters
        ----------
        step
            One frame of a sequence: its ``images``, each a single set image and its weight.

        Returns
        -------
        list of psychopy.visual.ImageStim
            The frame's stimuli, laid out.
        """
        stims = []
        for image in step["images"]:
            ((name, weight),) = image["terms"]
            stims.append(self.image_stim(self.set.read(name) * float(weight)))
        self.lay_out(stims)
        return stims

    def place(self, screen: dict) -> list:
        """The screen's images, uploaded and laid out in a row, centred, the set's gap apart.

        Parameters
        ----------
        screen
            The engine's screen; its ``images`` are placed.

        Returns
        -------
        list of psychopy.visual.ImageStim
            The stimuli, laid out.
        """
        stims = [self.stim(image) for image in screen.get("images", [])]
        self.lay_out(stims)
        return stims

    def lay_out(self, stims: list) -> list[Placement]:
        """Put ``stims`` in a row on whole pixels (:func:`glarelab.experiments.layout.row_layout`):
        each image pixel on one screen pixel.

        Parameters
        ----------
        stims
            The stimuli, left to right; their positions are set.

        Returns
        -------
        list of glarelab.experiments.layout.Placement
            Where each is drawn.
        """
        gap = self.set.geometry.get("gap_px", 40) if self.set else 0
        placements = row_layout(
            tuple(int(v) for v in self.window.size),
            [(int(s.size[0]), int(s.size[1])) for s in stims],
            gap_px=gap,
        )
        for stim, placement in zip(stims, placements, strict=True):
            stim.pos = placement.pos
        return placements

    def image_size(self, image: dict) -> tuple[int, int]:
        """(width, height) in pixels of a screen's image.

        Parameters
        ----------
        image
            A screen's image: its ``terms`` (``[(name, weight)]`` of the set's images) and
            ``role``.

        Returns
        -------
        tuple of int
            ``(width, height)``, pixels.
        """
        stim = self.stim(image)
        return int(stim.size[0]), int(stim.size[1])

    # --- what the screen shows ------------------------------------------------------------------

    def expected_codes(self, terms) -> tuple[np.ndarray, str]:
        """The codes the window must show for an image, (height, width, 3), top row first, at
        the window's bits, and where they come from: a set image as it is, encoded with the
        set's own calibration, has the codes of its codes PNG (``NAME.png`` for an 8-bit
        display, ``NAME_<bits>bit.png`` for a deeper one); any other image the calibration's
        encoding of its luminance.

        Parameters
        ----------
        terms
            The image as ``[(name, weight)]`` of the set's images.

        Returns
        -------
        codes : numpy.ndarray
            ``(height, width, 3)`` integer codes at the window's bits.
        source : str
            Where they come from (the set's PNG, or the calibration's encoding).
        """
        terms = [tuple(t) for t in terms]
        set_image = len(terms) == 1 and float(terms[0][1]) == 1.0
        set_bits = int(self.set.manifest["calibration"]["bit_depth"])
        png = self.set.folder / codes_png(str(terms[0][0]), set_bits)
        if set_image and self._set_calibration_used() and png.is_file():
            codes, bits = read_png_codes(png)
            source = f"{png.name} (the set's codes)"
        else:
            codes, _ = self.calibration.encode(self.set.compose(terms))
            bits = self.calibration.bit_depth
            source = "the calibration's codes of its luminance"
        codes = codes_at_bits(codes, bits, self.window_bits)
        if codes.ndim == 2:
            codes = np.repeat(codes[..., None], 3, axis=-1)
        return codes, source

    def _set_calibration_used(self) -> bool:
        self.codes(np.zeros((1, 1)))  # the calibration of an uncalibrated session, if none yet
        return self.calibration.to_json() == self.set.manifest["calibration"]

    def read_back(self, stim, placement: Placement) -> np.ndarray:
        """Draw ``stim`` alone at ``placement`` and read its pixels back from the frame buffer
        (codes at the window's bits, top row first); the back buffer is cleared after.

        Parameters
        ----------
        stim
            The stimulus.
        placement : glarelab.experiments.layout.Placement
            Where to draw it.

        Returns
        -------
        numpy.ndarray
            The codes read back, at the window's bits, top row first.
        """
        self.window.clearBuffer()
        stim.pos = placement.pos
        stim.draw()
        shown = read_framebuffer_codes(self.window, _box(placement), bits=self.window_bits)
        self.window.clearBuffer()
        return shown

    def check_presentation(self, screen: dict | None) -> dict | None:
        """Draw ``screen``'s images as a session places them, read them back from the frame
        buffer and compare each with its codes (:meth:`expected_codes`); None without images.
        A sequence (a night scene) is checked frame by frame, each drawn as
        :meth:`frame_stims` draws it for the presentation. The back buffer is cleared after.

        Parameters
        ----------
        screen
            The screen to check; None: nothing.

        Returns
        -------
        dict or None
            Each image's comparison with its expected codes, or None.
        """
        if screen is None or self.set is None or not screen.get("images"):
            return None
        images = []
        if screen.get("sequence"):
            for number, step in enumerate(screen["sequence"]):
                stims = self.frame_stims(step)
                images += self._compare(step["images"], stims, self.lay_out(stims), frame=number)
        else:
            stims = self.place(screen)
            images = self._compare(screen["images"], stims, self.lay_out(stims))
        size = [int(v) for v in self.window.size]
        framebuffer = [int(v) for v in getattr(self.window, "frameBufferSize", size)]
        return {
            "screen": f"{screen['kind']} of trial {screen.get('trial')}",
            "window_px": size,
            "framebuffer_px": framebuffer,
            "window_bits": self.window_bits,
            "images": images,
            "exact": framebuffer == size and all(i["exact_fraction"] == 1.0 for i in images),
        }

    def _compare(
        self, images: list[dict], stims: list, placements: list[Placement], *, frame=None
    ) -> list[dict]:
        """Draw ``stims`` at ``placements``, read each back and compare it with its codes."""
        self.window.clearBuffer()
        for stim in stims:
            stim.draw()
        found = []
        for image, placement in zip(images, placements, strict=True):
            expected, source = self.expected_codes(image["terms"])
            record = {"role": image["role"]} | ({} if frame is None else {"frame": frame})
            if not placement.inside:
                found.append(record | {"exact_fraction": 0.0, "off_window": True})
                continue
            shown = read_framebuffer_codes(self.window, _box(placement), bits=self.window_bits)
            equal = np.all(shown == expected, axis=-1)
            found.append(
                record
                | {
                    "terms": [[str(n), float(w)] for n, w in image["terms"]],
                    "size_px": [placement.width_px, placement.height_px],
                    "left_bottom_px": [placement.left_px, placement.bottom_px],
                    "exact_fraction": float(equal.mean()),
                    "worst_code_difference": int(np.abs(shown - expected).max()),
                    "expected": source,
                }
            )
        self.window.clearBuffer()
        return found
