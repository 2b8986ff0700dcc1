"""Running a study: the protocol engines, the session loop and the simulated observers.

Everything here runs without a screen; :mod:`glarelab.frontend` puts a session on one.

- :mod:`glarelab.experiments.session`: a session from its checks to its last trial on disk.
- :mod:`glarelab.experiments.loop`: the loop of screens, key presses and rows that a real
  screen, a scripted dry run and a simulated observer all go through.
- :mod:`glarelab.experiments.engine`: what every protocol engine shares; one engine per
  paradigm: :mod:`~glarelab.experiments.matching` (Yoshida et al. 2008),
  :mod:`~glarelab.experiments.staircase` (Spencer et al. 1995) and
  :mod:`~glarelab.experiments.rating` (Luidolt 2020), registered in
  :mod:`glarelab.experiments.paradigms`.
- Each paradigm's simulated participant sits beside its engine and answers its screens; what
  it perceives (the brightness model, its noise, the range it was fitted on, a set's images as
  the display shows them) is :mod:`glarelab.observers`.
- :mod:`glarelab.experiments.layout`: where a screen's images go, one image pixel on one
  screen pixel.
- :mod:`glarelab.experiments.data`: the session's files, written so that nothing collected is
  lost, and the lock that keeps one process on a session.
"""
