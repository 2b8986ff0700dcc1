"""Stimulus sets: the images a study shows, in cd/m², and the display codes that show them.

- :mod:`glarelab.stimuli.stimulus_set`: a set on disk, reproducible and self-describing (EXR
  luminance, 16-bit PNG codes, a manifest), built or verified from its protocol.
- One module per paradigm, registered in :mod:`glarelab.stimuli.paradigms`:
  :mod:`~glarelab.stimuli.matching` (Yoshida et al. 2008), :mod:`~glarelab.stimuli.staircase`
  (Spencer et al. 1995) and :mod:`~glarelab.stimuli.night` (the night street of a rating
  study, Luidolt 2020).
- What the stimuli are made of: :mod:`~glarelab.stimuli.shapes` (a disk, a row of images),
  :mod:`~glarelab.stimuli.backgrounds` and :mod:`~glarelab.stimuli.sky` (the procedural cloudy
  sky), :mod:`~glarelab.stimuli.apertures` (obstacle images for wave-optics glare).
- Files and previews: :mod:`~glarelab.stimuli.exr` (float32 OpenEXR) and
  :mod:`~glarelab.stimuli.preview` (8-bit PNG previews of a luminance image on a display).
"""
