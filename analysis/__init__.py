"""analysis package.

colour-science switches numpy's printing to its 1.13 legacy mode when it is first imported
(``np.set_printoptions(legacy="1.13")`` in ``colour/__init__.py``, 0.4), which prints floats with
12 significant digits; the analysis imports it here with numpy's options kept as they were, so
that importing glarelab's analysis leaves no global option changed behind it. The report's
tables are written with an explicit format anyway (:mod:`glarelab.analysis.report`).
"""

import sys as _sys

import numpy as _np

if "colour" not in _sys.modules:
    _options = _np.get_printoptions()
    try:
        import colour  # noqa: F401
    finally:
        _np.set_printoptions(**_options)
