"""colour-science, imported with numpy's print options kept as they were.

colour-science switches numpy's printing to its 1.13 legacy mode when it is first imported
(``np.set_printoptions(legacy="1.13")`` in ``colour/__init__.py``, 0.4), which prints floats
with 12 significant digits. Every module of the suite takes colour from here, so that using a
glare model leaves no global option of numpy changed behind it.
(tests/glare/test_global_state.py checks it in a fresh process.)
"""

import numpy as np

_options = np.get_printoptions()
try:
    import colour
finally:
    np.set_printoptions(**_options)
del _options

__all__ = ["colour"]
