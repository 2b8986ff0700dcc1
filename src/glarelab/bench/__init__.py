"""``glarelab bench``: what each speed knob costs in accuracy, in display codes.

One job per module: :mod:`~glarelab.bench.scenes` (the workloads, which glare's own tests
render too), :mod:`~glarelab.bench.peers` (what a user could write instead),
:mod:`~glarelab.bench.timing` (contenders timed side by side),
:mod:`~glarelab.bench.run` (every knob of the renderer on every workload),
:mod:`~glarelab.bench.processes` (one call in a fresh process, start-up, peak memory),
:mod:`~glarelab.bench.spectral` (the wave-optics colour methods),
:mod:`~glarelab.bench.report` (tables and Pareto plots) and
:mod:`~glarelab.bench.acuity` (``glarelab bench --acuity``).
"""
