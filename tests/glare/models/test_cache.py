"""The kernel cache on disk (glarelab.glare.models.cache): keys, integrity, concurrency, faults, eviction.

Every test points the cache at its own temporary folder; the suite's default cache is a
temporary folder too (conftest.py), never the user's.
"""

import os
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from glarelab import glare
from glarelab.glare.models.cache import KernelCache, default_cache, resolve_cache
from glarelab.glare.models.digitise import Kernel

SRC = Path(__file__).resolve().parents[3] / "src"  # this tree's package, not an installed one
SHAPE = (41, 41)


def _entries(cache: KernelCache) -> list[Path]:
    return sorted(cache.directory.glob("*.kernel"))


def _same(a: Kernel, b: Kernel) -> None:
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(np.asarray(a.energy_outside), np.asarray(b.energy_outside))
    assert a.pixel_deg == b.pixel_deg
    assert a.quadrature_error == b.quadrature_error
    assert a.description == b.description


@pytest.mark.parametrize(
    "model, colour",
    [
        (glare.VosGlare(), False),
        (glare.VosGlare(regime="mesopic"), True),
        (glare.VosGlare(flare_lines=True, seed=3), False),  # not symmetric: stored whole
        (glare.GaussianGlare(sigma_deg=0.2, sampling="pixel"), False),
    ],
    ids=["vos", "mesopic-rgb", "flare-lines", "gaussian"],
)
def test_a_cached_kernel_is_the_digitised_kernel(tmp_path, model, colour):
    cache = KernelCache(tmp_path)
    made = model.kernel(0.05, SHAPE, colour=colour)
    first = cache.kernel(model, 0.05, SHAPE, colour=colour)
    _same(first, made)
    assert len(_entries(cache)) == 1
    again = cache.kernel(model, 0.05, SHAPE, colour=colour, build=pytest.fail)  # not rebuilt
    _same(again, made)
    assert isinstance(again.energy_outside, type(made.energy_outside))


def test_every_parameter_is_in_the_key(tmp_path):
    cache = KernelCache(tmp_path)
    base = cache.key(glare.VosGlare(), 0.05, SHAPE, colour=False)
    others = [
        cache.key(glare.VosGlare(age=40.0), 0.05, SHAPE, colour=False),
        cache.key(glare.VosGlare(samples_per_pixel=11), 0.05, SHAPE, colour=False),
        cache.key(glare.VosGlare(regime="mesopic"), 0.05, SHAPE, colour=False),
        cache.key(  # the halo's spectrum (the mesopic PSF has a halo; the photopic none)
            glare.VosGlare(regime="mesopic", halo_spectrum=glare.HaloSpectrum(n_wavelengths=31)),
            0.05,
            SHAPE,
            colour=False,
        ),
        cache.key(glare.VosGlare(), np.nextafter(0.05, 1.0), SHAPE, colour=False),
        cache.key(glare.VosGlare(), 0.05, (41, 43), colour=False),
        cache.key(glare.VosGlare(), 0.05, SHAPE, colour=True),
        cache.key(glare.GaussianGlare(), 0.05, SHAPE, colour=False),
        cache.key(glare.WaveOpticsGlare(pupil_mm=4.0), 0.05, SHAPE, colour=False),
        cache.key(glare.WaveOpticsGlare(pupil_mm=5.0), 0.05, SHAPE, colour=False),
    ]
    assert None not in others
    assert len({base, *others}) == len(others) + 1
    assert cache.key(glare.VosGlare(), 0.05, SHAPE, colour=False) == base


def test_a_changed_parameter_is_digitised_not_read(tmp_path):
    cache = KernelCache(tmp_path)
    cache.kernel(glare.VosGlare(), 0.05, SHAPE)
    older = glare.VosGlare(age=65.0)
    got = cache.kernel(older, 0.05, SHAPE)
    _same(got, older.kernel(0.05, SHAPE))
    assert len(_entries(cache)) == 2


def test_a_model_without_a_faithful_repr_is_not_cached(tmp_path):
    class Plain:  # repr is an address: two different objects could share nothing
        def kernel(self, pixel_deg, shape, *, colour=False):
            return Kernel(values=np.ones((1, 1)), pixel_deg=pixel_deg)

    @dataclass(frozen=True)
    class WithArray(glare.GlareModel):  # a long array's repr is shortened with "..."
        weights: np.ndarray

        def kernel(self, pixel_deg, shape, *, colour=False):
            return Kernel(values=np.ones((1, 1)), pixel_deg=pixel_deg)

    cache = KernelCache(tmp_path)
    assert cache.key(Plain(), 0.1, (1, 1), colour=False) is None
    assert cache.key(WithArray(np.arange(5000.0)), 0.1, (1, 1), colour=False) is None
    renderer = glare.GlareRenderer(Plain(), pixel_deg=0.1, shape=(1, 1), cache=cache)
    assert renderer.kernel().values.shape == (1, 1)
    assert _entries(cache) == []


@pytest.mark.parametrize("damage", ["flip", "truncate", "empty", "garbage"])
def test_a_corrupt_entry_is_detected_removed_and_rebuilt(tmp_path, damage):
    cache = KernelCache(tmp_path)
    model = glare.VosGlare()
    made = cache.kernel(model, 0.05, SHAPE)
    (path,) = _entries(cache)
    data = bytearray(path.read_bytes())
    if damage == "flip":  # one bit of one kernel value
        data[len(data) // 2] ^= 0x10
    elif damage == "truncate":
        data = data[: len(data) - 100]
    elif damage == "empty":
        data = bytearray()
    else:
        data = bytearray(os.urandom(len(data)))
    path.write_bytes(bytes(data))
    key = cache.key(model, 0.05, SHAPE, colour=False)
    assert cache.get(key) is None
    assert not path.exists()  # removed, so that it is written again
    rebuilt = cache.kernel(model, 0.05, SHAPE)
    _same(rebuilt, made)
    assert cache.get(key) is not None


def _rewritten(data: bytes, header=None, values=None) -> bytes:
    """The entry with its header or values changed and its CRC-32 made to match again."""
    import json
    import struct
    import zlib

    magic = len(b"GLAREKERNEL\x00")
    (length,) = struct.unpack_from("<Q", data, magic)
    start = magic + 8
    stored = json.loads(data[start : start + length])
    array = np.frombuffer(data[start + length : -4], "<f8").copy()
    if header is not None:
        header(stored)
    if values is not None:
        values(array)
    text = json.dumps(stored).encode()
    text += b" " * (-(start + len(text)) % 8)
    body = data[:magic] + struct.pack("<Q", len(text)) + text + array.tobytes()
    return body + struct.pack("<I", zlib.crc32(body))


@pytest.mark.parametrize(
    "edit",
    [
        {"values": lambda v: v.__setitem__(slice(None), np.nan)},  # rendered a NaN image
        {"values": lambda v: v.__setitem__(3, np.inf)},
        {"values": lambda v: v.__setitem__(-1, np.nan)},  # one NaN, at the support's corner
        {"values": lambda v: v.__setitem__(0, np.inf)},  # on both axes of a quadrant
        {"values": lambda v: v.__setitem__(5, -np.inf)},
        {"values": lambda v: v.__setitem__(0, -1e-3)},
        {"values": lambda v: v.__imul__(2.0)},  # summed to 2 with its energy outside
        {"header": lambda h: h.__setitem__("shape", [1, -1])},  # a 1 × 441 kernel
        {"header": lambda h: h.__setitem__("energy_outside", -5.0)},
        {"header": lambda h: h.__setitem__("energy_outside", float("nan"))},
        {"header": lambda h: h.__setitem__("shape", [float("inf"), 21])},  # OverflowError
    ],
    ids=[
        "nan",
        "inf",
        "one-nan",
        "inf-centre",
        "minus-inf",
        "negative",
        "doubled",
        "shape",
        "outside-negative",
        "outside-nan",
        "shape-infinite",
    ],
)
def test_an_entry_whose_crc_matches_but_no_kernel_could_be_is_rebuilt(tmp_path, edit):
    cache = KernelCache(tmp_path)
    model = glare.VosGlare()
    made = cache.kernel(model, 0.05, SHAPE)
    (path,) = _entries(cache)
    path.write_bytes(_rewritten(path.read_bytes(), **edit))
    again = cache.kernel(model, 0.05, SHAPE)
    _same(again, made)
    assert cache.get(cache.key(model, 0.05, SHAPE, colour=False), SHAPE) is not None


def test_an_edited_header_under_the_old_crc_is_refused_before_it_is_read(tmp_path):
    """The header is parsed while the CRC-32 is taken on another core: an entry edited in a
    text editor (its shape made infinite, its CRC left as it was) is refused and rebuilt,
    not an OverflowError out of the render."""
    import zlib

    cache = KernelCache(tmp_path)
    model = glare.VosGlare()
    made = cache.kernel(model, 0.05, SHAPE)
    (path,) = _entries(cache)
    data = path.read_bytes()
    edited = _rewritten(data, header=lambda h: h.__setitem__("shape", [float("inf"), 21]))
    edited = edited[:-4] + data[-4:]  # the old CRC
    assert edited[-4:] != zlib.crc32(edited[:-4]).to_bytes(4, "little")
    path.write_bytes(edited)
    assert cache.get(cache.key(model, 0.05, SHAPE, colour=False)) is None
    _same(cache.kernel(model, 0.05, SHAPE), made)


@pytest.mark.parametrize("colour", [False, True])
def test_a_kernel_admitting_a_share_of_the_light_is_served_from_the_cache(tmp_path, colour):
    """Under Luidolt's pupil convention a wave or hybrid kernel sums to less than 1 with its
    energy outside: the cache serves it, not digitising it again each time."""
    wave = glare.WaveOpticsGlare(pupil_convention="Luidolt2020", eyelashes=False, particles=0)
    cache = KernelCache(tmp_path)
    for model in (wave, glare.HybridGlare(wave=wave)):
        made = cache.kernel(model, 0.05, SHAPE, colour=colour)
        _same(cache.kernel(model, 0.05, SHAPE, colour=colour, build=pytest.fail), made)


def test_an_entry_under_another_name_is_not_served(tmp_path):
    """A file copied or renamed onto another key's name holds the wrong kernel: refused."""
    cache = KernelCache(tmp_path)
    cache.kernel(glare.VosGlare(), 0.05, SHAPE)
    (path,) = _entries(cache)
    other = cache.key(glare.VosGlare(age=50.0), 0.05, SHAPE, colour=False)
    path.rename(cache.path(other))
    assert cache.get(other) is None


WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from glarelab import glare
    from glarelab.glare.models.cache import KernelCache

    cache = KernelCache(sys.argv[1])
    model = glare.VosGlare(regime=sys.argv[2])
    for _ in range(int(sys.argv[3])):
        kernel = cache.kernel(model, 0.02, (301, 301))
        assert np.array_equal(kernel.values, model.kernel(0.02, (301, 301)).values)
        key = cache.key(model, 0.02, (301, 301), colour=False)
        cache.path(key).unlink(missing_ok=True)  # make the next round write again
    """
)


def test_two_processes_filling_the_cache_at_once(tmp_path):
    """Two writers of the same entries, each reading back and removing them in a loop: every
    kernel read is the digitised one, and no partial file is left behind."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    writers = [
        subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path), "photopic", "6"], env=env)
        for _ in range(2)
    ]
    assert [w.wait(timeout=240) for w in writers] == [0, 0]
    assert list(tmp_path.glob("*.part")) == []
    cache = KernelCache(tmp_path)
    model = glare.VosGlare()
    _same(cache.kernel(model, 0.02, (301, 301)), model.kernel(0.02, (301, 301)))


FULL_DISK = textwrap.dedent(
    """
    import resource, signal, sys, warnings
    import numpy as np
    from glarelab import glare
    from glarelab.glare.models.cache import KernelCache

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes past the limit fail with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))
    cache = KernelCache(sys.argv[1])
    model = glare.VosGlare()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        kernel = cache.kernel(model, 0.02, (401, 401))  # 645 kB as a quadrant: refused
    assert np.array_equal(kernel.values, model.kernel(0.02, (401, 401)).values)
    assert any("could not be written" in str(w.message) for w in caught), caught
    small = cache.kernel(model, 0.02, (101, 101))  # fits: written
    print(len(list(cache.directory.glob("*.kernel"))), len(list(cache.directory.glob("*.part"))))
    """
)


def test_a_full_disk_skips_the_entry_and_returns_the_right_kernel(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    done = subprocess.run(
        [sys.executable, "-c", FULL_DISK, str(tmp_path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["1", "0"]  # the small entry only, no temporary file left
    cache = KernelCache(tmp_path)
    model = glare.VosGlare()
    _same(cache.kernel(model, 0.02, (101, 101), build=pytest.fail), model.kernel(0.02, (101, 101)))


def test_an_unwritable_folder_warns_and_renders(tmp_path):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("")
    cache = KernelCache(blocker / "kernels")
    with pytest.warns(UserWarning, match="could not be written"):
        kernel = cache.kernel(glare.VosGlare(), 0.05, SHAPE)
    _same(kernel, glare.VosGlare().kernel(0.05, SHAPE))


def test_least_recently_used_entries_are_evicted(tmp_path):
    model = glare.VosGlare()
    one = KernelCache(tmp_path).kernel(model, 0.05, (101, 101))
    size = next(tmp_path.glob("*.kernel")).stat().st_size
    cache = KernelCache(tmp_path, max_bytes=int(2.5 * size))
    keys = []
    for pixel in (0.05, 0.06, 0.07):
        cache.kernel(model, pixel, (101, 101))
        keys.append(cache.key(model, pixel, (101, 101), colour=False))
        path = cache.path(keys[-1])
        os.utime(path, (path.stat().st_atime, 1e9 + len(keys)))  # a clear order of use
    assert cache.get(keys[0]) is None  # the oldest went when the third was written
    assert cache.get(keys[1]) is not None  # read: now the most recently used
    os.utime(cache.path(keys[1]), None)
    cache.kernel(model, 0.08, (101, 101))
    assert cache.get(keys[2]) is None and cache.get(keys[1]) is not None
    assert cache.info()["bytes"] <= cache.max_bytes
    _same(cache.get(keys[1]), model.kernel(0.06, (101, 101)))
    assert one.values.shape == (101, 101)


def test_a_kernel_larger_than_the_cache_is_not_stored(tmp_path):
    cache = KernelCache(tmp_path, max_bytes=1000)
    kernel = cache.kernel(glare.VosGlare(), 0.05, (101, 101))
    assert kernel.values.shape == (101, 101) and _entries(cache) == []


def test_clear_and_info(tmp_path):
    cache = KernelCache(tmp_path)
    for pixel in (0.05, 0.1):
        cache.kernel(glare.VosGlare(), pixel, SHAPE)
    (tmp_path / ".left-over.part").write_bytes(b"x")
    info = cache.info()
    assert info["entries"] == 2 and info["bytes"] > 0 and info["directory"] == str(tmp_path)
    assert cache.clear() == 2
    assert list(tmp_path.iterdir()) == []


def test_bad_sizes_are_refused(tmp_path, monkeypatch):
    for bad in (0, -1, float("nan"), "lots"):
        with pytest.raises(ValueError, match="max_bytes"):
            KernelCache(tmp_path, max_bytes=bad)
    monkeypatch.setenv("GLARELAB_CACHE_MAX_MB", "many")
    with pytest.raises(ValueError, match="GLARELAB_CACHE_MAX_MB"):
        KernelCache(tmp_path)
    with pytest.raises(ValueError, match="cache must be"):
        resolve_cache(3)


def test_the_environment_chooses_the_folder_and_turns_it_off(tmp_path, monkeypatch):
    monkeypatch.setenv("GLARELAB_CACHE", str(tmp_path))
    monkeypatch.delenv("GLARELAB_NO_CACHE", raising=False)
    assert default_cache().directory == tmp_path / "kernels"
    monkeypatch.setenv("GLARELAB_NO_CACHE", "1")
    assert default_cache() is None
    renderer = glare.GlareRenderer(glare.VosGlare(), pixel_deg=0.05, shape=(21, 21))
    renderer.kernel()
    assert not (tmp_path / "kernels").exists()
    monkeypatch.setenv("GLARELAB_NO_CACHE", "0")
    assert default_cache() is not None
    for unclear in ("maybe", "yes", "true", " 1", "2"):  # 'maybe' used the cache unasked
        monkeypatch.setenv("GLARELAB_NO_CACHE", unclear)
        with pytest.raises(ValueError, match=rf"^GLARELAB_NO_CACHE must be 1 .*got {unclear!r}"):
            default_cache()


@pytest.mark.parametrize("megabytes", ["-5", "0", "nan", "inf", "-inf"])
def test_a_size_out_of_range_names_the_variable_and_its_value(tmp_path, monkeypatch, megabytes):
    # -5 was refused as 'max_bytes ... got -5242880.0', naming neither the variable nor '-5'
    monkeypatch.setenv("GLARELAB_CACHE_MAX_MB", megabytes)
    with pytest.raises(ValueError, match=rf"^GLARELAB_CACHE_MAX_MB .* MiB, got '{megabytes}'$"):
        KernelCache(tmp_path)


def test_the_user_cache_folder_honours_xdg_cache_home(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "GLARELAB_CACHE"}
    env |= {"PYTHONPATH": str(SRC), "XDG_CACHE_HOME": str(tmp_path)}
    code = "from glarelab.glare.models.cache import KernelCache; print(KernelCache().directory)"
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert Path(done.stdout.strip()) == tmp_path / "glarelab" / "kernels"


def test_renderers_share_kernels_through_the_cache(tmp_path):
    """A second renderer (another image set, another run) reads the reference kernel and the
    coarse far-tail kernels instead of digitising them, and renders the same image."""
    cache = KernelCache(tmp_path)
    image = np.full((96, 96), 30.0)
    image[40:42, 50:52] = 1e7
    lines = []
    first = glare.GlareRenderer(
        glare.VosGlare(), pixel_deg=0.05, shape=image.shape, cache=cache, log=lines.append
    ).render(image)
    assert any("digitising" in line for line in lines)
    lines.clear()
    second = glare.GlareRenderer(
        glare.VosGlare(), pixel_deg=0.05, shape=image.shape, cache=cache, log=lines.append
    ).render(image)
    assert not any("digitising" in line for line in lines), lines
    assert any("read from the cache" in line for line in lines)
    np.testing.assert_array_equal(first.image, second.image)
    plain = glare.add_glare(image, glare.VosGlare(), pixel_deg=0.05, cache=False)
    np.testing.assert_array_equal(first.image, plain)


def test_a_symmetric_kernel_is_read_and_spread_as_its_quadrant(tmp_path):
    """The entry of a radial kernel is its quadrant, read without a copy; a render that takes
    the direct path spreads from it and never unfolds the full kernel (a 134 MB array at
    4095²), and gives the same image as the full kernel: the same float32 spans summed in
    the same order, but that BLAS may round the ends of a run otherwise (a few pixels
    apart by 7.8e-8 of their value; the spans' bound is 3.9e-6)."""
    cache = KernelCache(tmp_path)
    image = np.full((96, 96), 30.0)
    image[40:42, 50:52] = 1e7
    model = glare.VosGlare()
    glare.add_glare(image, model, pixel_deg=0.05, cache=cache)
    renderer = glare.GlareRenderer(model, pixel_deg=0.05, shape=image.shape, cache=cache)
    result = renderer.render(image)
    assert result.plan.path == "direct"
    kernel = renderer.kernel()
    assert kernel.quadrant is not None and not kernel.quadrant.flags.writeable
    assert kernel._values is None  # the full kernel was never made
    full = glare.GlareRenderer(
        model,
        pixel_deg=0.05,
        shape=image.shape,
        kernel=model.kernel(0.05, (191, 191)).replace(values=kernel.values),
    )
    assert result.plan.direct_precision == "float32"
    np.testing.assert_allclose(full.render(image).image, result.image, rtol=1e-6, atol=0)


def test_a_fifo_under_an_entrys_name_is_a_miss_not_a_hang(tmp_path):
    # reading a FIFO waits for a writer for ever; the cache checks what it opened first
    cache = KernelCache(tmp_path)
    model = glare.GaussianGlare(sigma_deg=0.2, sampling="pixel")
    key = cache.key(model, 0.05, SHAPE, colour=False)
    os.mkfifo(cache.path(key))
    done = subprocess.run(  # in a process of its own: a hang fails the test, not the suite
        [sys.executable, "-c", textwrap.dedent(f"""
            from glarelab.glare.models.cache import KernelCache
            print(KernelCache({str(tmp_path)!r}).get({key!r}))
        """)],
        capture_output=True, text=True, timeout=20,
        env={**os.environ, "PYTHONPATH": str(SRC)},
    )  # fmt: skip
    assert done.returncode == 0 and done.stdout == "None\n", done.stderr
    made = cache.kernel(model, 0.05, SHAPE)  # digitised and stored over the FIFO
    assert cache.path(key).is_file() and not cache.path(key).is_fifo()
    _same(cache.get(key), made)


def test_a_cache_variable_naming_a_file_is_refused_by_name(tmp_path, monkeypatch):
    """``GLARELAB_CACHE=FILE glarelab cache info`` reported an empty cache in FILE/kernels."""
    from glarelab.glare.models.cache import CACHE_DIR_ENV, KernelCache

    (tmp_path / "f").write_text("x\n")
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path / "f"))
    with pytest.raises(ValueError, match=rf"^{CACHE_DIR_ENV}=.*f: not a folder"):
        KernelCache()


def test_another_obstacle_image_is_another_key(tmp_path):
    """The obstacle image is left out of the wave model's repr: a render with another aperture
    image read the first image's kernel from the cache."""
    cache = KernelCache(tmp_path)
    a = np.ones((64, 64))
    a[:, 30:34] = 0.0  # a vertical bar
    b = a.T.copy()  # a horizontal one
    keys = [
        cache.key(_wave(image), 0.05, SHAPE, colour=False)
        for image in (a, b, a.astype(np.float32), a[:32], None)
    ]
    assert None not in keys and len(set(keys)) == len(keys)
    hybrid = [
        cache.key(
            glare.HybridGlare(wave=_wave(image)),
            0.05,
            SHAPE,
            colour=False,
        )
        for image in (a, b)
    ]
    assert hybrid[0] != hybrid[1]
    again = _wave(a.copy())
    assert cache.key(again, 0.05, SHAPE, colour=False) == keys[0]


def _wave(image):
    if image is None:
        return glare.WaveOpticsGlare()
    return glare.WaveOpticsGlare(obstacle_image=image, obstacle_spacing_mm=0.1)


def test_a_bool_a_fraction_of_a_byte_or_less_than_a_mib_is_refused(tmp_path, monkeypatch):
    """max_bytes=True became 1 byte, 0.5 became 0 and GLARELAB_CACHE_MAX_MB=1e-9 became 0:
    nothing was ever kept, and nothing said so."""
    for bad in (True, 0.5, 2.5):
        with pytest.raises(ValueError, match=r"^max_bytes must be a positive whole number"):
            KernelCache(tmp_path, max_bytes=bad)
    assert KernelCache(tmp_path, max_bytes=1e9).max_bytes == 10**9
    for small in ("1e-9", "0.5"):
        monkeypatch.setenv("GLARELAB_CACHE_MAX_MB", small)
        with pytest.raises(ValueError, match=rf"at least 1 MiB .* turns it off\), got '{small}'$"):
            KernelCache(tmp_path)
    monkeypatch.setenv("GLARELAB_CACHE_MAX_MB", "1.5")
    assert KernelCache(tmp_path).max_bytes == 1572864


def test_a_cache_folder_given_with_a_tilde_is_the_home_folders(monkeypatch, tmp_path):
    # GLARELAB_CACHE='~/cache' (quoted, the shell leaves it) made a folder named '~'
    from glarelab.glare.models.cache import cache_root

    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("GLARELAB_CACHE", "~/lab-cache")
    assert cache_root() == tmp_path / "lab-cache"
    assert KernelCache().directory == tmp_path / "lab-cache" / "kernels"
