"""The participant dialog of ``glarelab run`` without ``--participant``: PsychoPy's dialog,
asking again, with what was typed kept and the whole problem written above the fields, until
every entry is valid. Sex and vision correction start as ``--sex`` and ``--vision`` gave them,
else empty: only what the experimenter chooses is recorded (an empty one is not given)."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable

from glarelab.frontend.window import qt_dialog_available, x_display_answers

__all__ = ["experiment_info"]


def experiment_info(
    args: argparse.Namespace,
    *,
    check_age: Callable[[str], int],
    vision: tuple[str, ...],
) -> None:
    """Ask for the participant's details in a dialog, as PsychoPy's experiment info does, and
    set them on ``args`` (participant, session, age, sex, vision); ``check_age`` checks an age
    as the command line does, ``vision`` are the vision corrections offered.

    Parameters
    ----------
    args
        The ``run`` command's options; the answers are set on it.
    check_age
        Takes the age as typed and returns it as a whole number of years, raising
        :class:`argparse.ArgumentTypeError` for one the command line would refuse.
    vision
        The vision corrections offered (``'none'``, ``'glasses'``, ...).

    Raises
    ------
    ValueError
        Without a display for the dialog, or without Qt's libraries.
    """
    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        raise ValueError("--participant is required (no display for the participant dialog)")
    if sys.platform.startswith("linux") and not x_display_answers():  # Qt would abort
        raise ValueError(
            f"--participant is required: no display answers at DISPLAY="
            f"{os.environ.get('DISPLAY', '')!r} to open the participant dialog on; run it on "
            "the lab's screen, or give --participant ID (nothing was run or written)"
        )
    if not qt_dialog_available():
        raise ValueError(
            "--participant is required: the participant dialog needs Qt's X11 libraries "
            "(Debian: libxcb-cursor0)"
        )
    from psychopy import gui

    from glarelab.experiments.data import check_session_id

    entered = {
        "participant": "",
        "session": args.session,
        "age": args.age,
        "sex": getattr(args, "sex", None) or "",  # as given on the command line
        "vision": getattr(args, "vision", None) or "",
    }
    problem = None
    while True:  # a bad entry is named and asked again, with what was typed kept
        dialog = gui.Dlg(title=f"glarelab {args.title}")
        if problem:  # the whole message, wrapped: a one-line field would cut it
            dialog.addText(problem, color="red").setWordWrap(True)
        dialog.addField("participant", initial=entered["participant"])
        dialog.addField("session", initial=str(entered["session"]))
        dialog.addField("age", initial="" if entered["age"] is None else str(entered["age"]))
        # nothing chosen is recorded as not given: the first choice is empty
        dialog.addField("sex", initial=entered["sex"], choices=["", "f", "m", "x"])
        dialog.addField("vision", initial=entered["vision"], choices=["", *vision])
        data = dialog.show()
        if not dialog.OK:
            raise ValueError("the participant dialog was cancelled: nothing was run or written")
        keys = ("participant", "session", "age", "sex", "vision")
        values = data if isinstance(data, dict) else dict(zip(keys, data, strict=True))
        entered = {key: values[key] for key in keys}
        entered["participant"] = str(entered["participant"]).strip()
        try:
            session = int(str(entered["session"]).strip())
            if session < 1:
                raise ValueError(f"session must be a whole number from 1; got {session}")
            age = check_age(str(entered["age"]).strip()) if str(entered["age"]).strip() else None
            check_session_id(entered["participant"], session)
        except (ValueError, argparse.ArgumentTypeError) as error:
            message = str(error)
            if "invalid literal" in message:
                message = f"session must be a whole number from 1; got {entered['session']!r}"
            problem = message
            continue
        args.participant, args.session, args.age = entered["participant"], session, age
        break
    args.sex = str(entered["sex"] or "") or None
    args.vision = str(entered["vision"] or "") or None
