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
    """Builder component: one image of a glarelab stimulus set, code for code."""

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
