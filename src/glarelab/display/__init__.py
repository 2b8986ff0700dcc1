"""The lab's display, without PsychoPy: calibration, photometers and the checks before a session.

- :mod:`glarelab.display.calibration`: from photometer readings to the luminance ↔ drive-code
  conversion of a display (fit, verification, encoding, the protocols' synthetic displays).
- :mod:`glarelab.display.photometer`: photometers on a serial port through PsychoPy's hardware
  plugins (imported only when a photometer is opened), and the reading of one patch.
- :mod:`glarelab.display.measure`: the measurement session behind ``glarelab calibrate
  measure`` (patches, readings, resuming, locking); its screen is
  :mod:`glarelab.frontend.measure`.
- :mod:`glarelab.display.checks`: the screen and the calibration checked against the
  protocol before the first trial.
"""
