"""The Builder component of glarelab's PsychoPy plugin: a set's image, code for code.

:class:`SetImageComponent` is Builder's Image component for a glarelab stimulus set: it
writes :class:`glarelab.frontend.psychopy_plugin.SetImageStim` into the compiled experiment,
so a set for a 10-bit display is shown with the display's codes (PsychoPy's Image component
would show its 16-bit codes file as black and white, its 8-bit ``NAME.png`` at 8 bits). Its
parameters are those of an Image component that can show an image 1:1: the image file, the
position in pixels, and the timing; units are pixels, the size is the image's own, there is no
interpolation, colour or mask. PsychoPy lists it under Stimuli once the glarelab plugin is
loaded at start-up (registered by the ``psychopy.experiment.components`` entry point in
glarelab's ``pyproject.toml``). The experiment's window must have the set's bits: Builder's
Experiment settings have no bits per channel (PsychoPy 2026.2), so for a 10-bit set compile the
experiment to a script and add ``bpc=(10, 10, 10)`` to its ``visual.Window(...)``; on Builder's
8-bit window the component shows the nearest 8-bit codes.
"""

from __future__ import annotations

from typing import ClassVar

from psychopy.experiment.components import BaseVisualComponent, Param, getInitVals
from psychopy.experiment.components.image import ImageComponent

__all__ = ["SetImageComponent"]

#: the parameters of the visual base class a 1:1 image cannot honour
_FIXED = ("color", "colorSpace", "fillColor", "borderColor", "contrast", "size", "units")


class SetImageComponent(BaseVisualComponent):
    """Builder component: one image of a glarelab stimulus set, code for code.

    Builder makes it with each parameter's value as text (a value, or ``$`` and Python code);
    the units are always pixels and the size is the image's own.

    Parameters
    ----------
    exp : psychopy.experiment.Experiment
        The experiment the component belongs to (its imports get ``SetImageStim``).
    parentName
        The name of the routine that holds the component.
    name
        The component's name, a Python identifier: the stimulus's variable in the compiled
        script (default ``"set_image"``).
    image
        The stimulus set's ``NAME.png`` (a path, relative to the experiment, or code); its
        ``NAME_10bit.png`` beside it is shown on a 10-bit set's display.
    pos
        Centre of the image, px from the window's centre, ``(x, y)`` (x rightwards, y
        upwards; default ``(0, 0)``).
    ori
        Orientation, degrees, clockwise (default 0).
    startType : {"time (s)", "frame N", "condition"}
        How ``startVal`` is read, as in every Builder component.
    startVal
        When the image appears: seconds, a frame number or a Python condition, by
        ``startType`` (default 0.0 s).
    stopType : {"duration (s)", "duration (frames)", "time (s)", "frame N", "condition"}
        How ``stopVal`` is read, as in every Builder component.
    stopVal
        When the image goes: seconds, frames or a Python condition, by ``stopType``
        (default 1.0 s); empty: never within the routine.
    startEstim
        The expected start, s, for Builder's timeline when ``startVal`` is not a number
        (default ``""``: none).
    durationEstim
        The expected duration, s, for Builder's timeline when ``stopVal`` is not a number
        (default ``""``: none).
    """

    categories: ClassVar[list[str]] = ["Stimuli"]
    targets: ClassVar[list[str]] = ["PsychoPy"]
    iconFile = ImageComponent.iconFile  # an image, as Builder draws its Image component
    iconSVG = getattr(ImageComponent, "iconSVG", None)
    tooltip = "Set image: an image of a glarelab stimulus set, code for code (any bit depth)"

    def __init__(
        self,
        exp,
        parentName,
        name="set_image",
        image="",
        pos=(0, 0),
        ori=0,
        startType="time (s)",
        startVal=0.0,
        stopType="duration (s)",
        stopVal=1.0,
        startEstim="",
        durationEstim="",
    ):
        super().__init__(
            exp,
            parentName,
            name=name,
            units="pix",
            pos=pos,
            ori=ori,
            startType=startType,
            startVal=startVal,
            stopType=stopType,
            stopVal=stopVal,
            startEstim=startEstim,
            durationEstim=durationEstim,
        )
        self.type = "SetImage"
        self.url = "https://github.com/glarelab/glarelab#stimuli-in-your-own-psychopy-experiment"
        self.exp.requireImport(
            importName="SetImageStim", importFrom="glarelab.frontend.psychopy_plugin"
        )
        for fixed in _FIXED:
            self.params.pop(fixed, None)
        self.order += ["image"]
        self.params["image"] = Param(
            image,
            valType="file",
            inputType="file",
            allowedTypes=[],
            categ="Basic",
            updates="constant",
            allowedUpdates=["constant", "set every repeat"],
            hint="A stimulus set's NAME.png (its NAME_10bit.png beside it is shown on a "
            "10-bit set's display)",
            label="Image",
        )
        self.params["pos"].hint = "Centre of the image, in pixels from the window's centre"

    def writeInitCode(self, buff):
        """Write the code that makes the stimulus, a
        :class:`~glarelab.frontend.psychopy_plugin.SetImageStim` of the window ``win``,
        before the experiment's routines run. An image set every repeat is given as the
        routine starts (``image=None`` here).

        Parameters
        ----------
        buff : psychopy.experiment.IndentingBuffer
            The compiled script's buffer, at the indentation of the experiment's
            initialisation code.
        """
        inits = getInitVals(self.params, "PsychoPy")
        if self.params["image"].updates != "constant":
            inits["image"].val, inits["image"].valType = None, "code"  # set as its routine starts
        depth = -self.getPosInRoutine()
        buff.writeIndentedLines(
            f"{inits['name']} = SetImageStim(\n"
            f"    win=win, name='{inits['name']}',\n"
            f"    image={inits['image']}, pos={inits['pos']}, ori={inits['ori']},\n"
            f"    opacity={inits['opacity']}, depth={depth:.1f})\n"
        )
