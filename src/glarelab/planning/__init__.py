"""Planning a study before running it: power and sample size from simulated observers, and
sweeps over a protocol's parameters, run on Dask from a laptop to a cluster.

This package sits above the others: it runs the experiments' simulated sessions and the
analysis' tests on them (neither of which imports it).

- :mod:`glarelab.planning.effects`: each test of a protocol's analysis as an effect with its
  p-values and effect size; the correction an ANOVA effect is judged by.
- :mod:`glarelab.planning.simulate`: one simulated study at several sample sizes.
- :mod:`glarelab.planning.power`: power with binomial intervals, effect sizes, recommended sample
  sizes, power curves.
- :mod:`glarelab.planning.analytic`: the exact power of a one-way repeated-measures ANOVA under
  sphericity (noncentral F), the check of the simulated power.
- :mod:`glarelab.planning.grid`: a grid of protocol parameters (``--set KEY=V1,V2``).
- :mod:`glarelab.planning.sweep`: the stimulus sets of a grid, optionally simulated.
- :mod:`glarelab.planning.execute`: tasks on Dask, results streamed to disk, resumed after a kill.
"""
