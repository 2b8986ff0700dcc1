"""glarelab package."""
