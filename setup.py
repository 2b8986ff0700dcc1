"""The build step pyproject.toml cannot say: the example scenes and readings of the repository
(examples/, calibrations/) installed inside the package as ``glarelab/shipped``, so that
``glarelab examples DEST`` writes them out for a pip user as a clone has them."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
# the files a clone has and a wheel ships (MANIFEST.in puts the same in the sdist); a lab's own
# calibrations in calibrations/ are not among them
SHIPPED = {
    "examples": ["*.exr"],
    "calibrations": ["README.md", "example-readings*.csv", "SYNTHETIC-*.json"],
}


class BuildWithExamples(build_py):
    def run(self):
        super().run()
        target = Path(self.build_lib) / "glarelab" / "shipped"
        for folder, patterns in SHIPPED.items():
            for pattern in patterns:
                for source in sorted((ROOT / folder).glob(pattern)):
                    destination = target / folder / source.name
                    destination.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(source, destination)


setup(cmdclass={"build_py": BuildWithExamples})
