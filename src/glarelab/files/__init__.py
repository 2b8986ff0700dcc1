"""Files and folders written safely: the suite's lowest layer, importing nothing of it.

- :mod:`glarelab.files.atomic`: every file written to a temporary name beside its target and
  renamed when complete (fsync'd), so a failed or killed write leaves the earlier file or none;
  folders replaced whole.
- :mod:`glarelab.files.folders`: output folders that never take someone else's files (the
  listing ``.glarelab-files.json`` of the files glarelab wrote there).
- :mod:`glarelab.files.locks`: one process at a time on a file (a session, a measurement, a
  power run).
- :mod:`glarelab.files.memory`: work that needs more memory than the system has refused
  before anything is allocated.
- :mod:`glarelab.files.values`: which values are real and whole numbers (not bools, strings
  or masked arrays), for every layer's boundary checks.

Every other package may import this one; it imports nothing of glarelab, so that even
:mod:`glarelab.glare`'s kernel cache writes its files the same safe way.
"""
