"""Write the example scenes of ``examples/``: small linear luminance images (cd/m², float32
OpenEXR) to try ``glarelab render`` on before a scene of one's own is at hand.

Run from the repository's root: ``python scripts/example_scenes.py``. The scenes are seeded, so
the files are the same on every run.
"""

from pathlib import Path

import numpy as np

from glarelab.stimuli.exr import write_exr
from glarelab.stimuli.sky import cloudy_sky

PIXEL_DEG = 0.0119  # the README's --pixel-deg: Yoshida et al.'s display at 1 m
SHAPE = (160, 240)  # 1.9° × 2.9°


def disk(shape, centre_px, radius_px):
    rows, columns = np.indices(shape)
    return np.hypot(rows - centre_px[0], columns - centre_px[1]) <= radius_px


def main(out: Path = Path("examples")) -> None:
    out.mkdir(exist_ok=True)
    rng = np.random.default_rng(2008)
    sky = cloudy_sky(
        SHAPE,
        pixel_deg=PIXEL_DEG,
        rng=rng,
        mean_cd_m2=150.0,
        contrast=0.15,
        cloud_min_deg=0.1,
        cloud_max_deg=3.0,
        slope=1.0,
        ceiling_cd_m2=220.0,
    )
    sky[disk(SHAPE, (80, 120), 0.15 / PIXEL_DEG)] = 5000.0  # Yoshida's 0.3° disk
    write_exr(out / "scene.exr", sky.astype(np.float32))
    night = np.full(SHAPE, 0.5)
    for centre in ((60, 70), (100, 170)):
        night[disk(SHAPE, centre, 2.0)] = 20000.0  # two street lamps
    write_exr(out / "night.exr", night.astype(np.float32))


if __name__ == "__main__":
    main()
