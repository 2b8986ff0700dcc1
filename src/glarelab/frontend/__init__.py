"""The PsychoPy front-end: the one package of the suite that imports PsychoPy.

Everything else (protocol engines, simulated observers, calibration, analysis) runs and is
tested without a screen; this package puts it on one.

- :mod:`glarelab.frontend.window`: the window and keyboard of every glarelab screen (opening
  it at the display's bits, reading keys and typed text, reading the frame buffer back).
- :mod:`glarelab.frontend.session`: the device a session loop drives on a real screen
  (images drawn code for code, timed presentations, key presses, records).
- :mod:`glarelab.frontend.measure`: the full-field patches a photometer reads during
  ``glarelab calibrate measure``.
- :mod:`glarelab.frontend.check_display`: ``glarelab check-display``, the lab's display
  measured as a session will use it.

PsychoPy itself is imported inside functions, so that importing this package costs nothing
until a window opens.
"""
