"""analysis package.

colour-science (the sRGB encoding of :func:`glarelab.analysis.stimulus_figures.to_srgb8`) is
taken from :mod:`glarelab.glare._colour`, which imports it with numpy's print options kept as
they were, so that the analysis leaves no global option changed behind it. The report's tables
are written with an explicit format anyway (:mod:`glarelab.analysis.report`).
"""
