"""The glarelab command line: ``glarelab render``, ``glarelab demo``."""
