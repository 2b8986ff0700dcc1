"""Properties of reading a patch and of resuming a measurement, at their borders."""

import json

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.display.measure import MeasurementSession
from glarelab.display.photometer import PatchProtocol, measure_patch

luminances = st.floats(0.0, 1e5, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(
    values=st.lists(luminances, min_size=30, max_size=30),
    readings=st.integers(1, 5),
    repeats=st.integers(0, 4),
    spread=st.floats(1e-4, 0.5),
)
def test_a_patch_keeps_every_reading_and_accepts_only_agreeing_ones(
    values, readings, repeats, spread
):
    protocol = PatchProtocol(
        readings=readings, settle_s=0, spread_fraction=spread, repeats=repeats
    )
    source, kept = iter(values), []
    result = measure_patch(lambda: (next(source), "r"), protocol, keep=kept.append)
    assert [row["cd_m2"] for row in kept] == result.readings  # every reading, in order
    assert len(result.readings) == readings * result.sets and result.sets <= repeats + 1
    last = result.readings[-readings:]
    assert result.luminance_cd_m2 == float(np.median(last))
    agrees = max(last) - min(last) <= protocol.allowed_spread(float(np.median(last)))
    assert agrees != bool(result.flags)  # flagged exactly when even the last set disagreed
    for index in range(result.sets - 1):  # every earlier set disagreed
        earlier = result.readings[index * readings : (index + 1) * readings]
        assert max(earlier) - min(earlier) > protocol.allowed_spread(float(np.median(earlier)))


def display(code):
    return 0.3 + 199.7 * (code / 255) ** 2.4


@settings(max_examples=12, deadline=None)
@given(stop=st.integers(1, 14), seed=st.integers(0, 2**16), typo=st.booleans())
def test_a_session_resumed_anywhere_ends_as_the_one_never_stopped(
    tmp_path_factory, stop, seed, typo
):
    folder = tmp_path_factory.mktemp("resume")

    def reading(code, count):  # a misread value once (re-measured later) when typo
        return display(code) / 10 if typo and count == 2 else display(code)

    def run(session, start=0):
        count = start
        while session.phase != "done":
            code = session.current()["code"]
            session.record(reading(code, count), readings=[1.0, 2.0], source="photometer")
            count += 1
        return session

    whole = run(
        MeasurementSession(
            bit_depth=8, out=folder / "a.json", rng=np.random.default_rng(seed), points=9
        )
    )
    part = MeasurementSession(
        bit_depth=8, out=folder / "b.json", rng=np.random.default_rng(seed), points=9
    )
    for count in range(stop):
        if part.phase == "done":
            break
        part.record(
            reading(part.current()["code"], count), readings=[1.0, 2.0], source="photometer"
        )
    if part.phase == "done":
        return
    resumed = run(MeasurementSession.resume(part.session_path, folder / "b.json"), len(part.log))
    a = json.loads(whole.session_path.read_text())
    b = json.loads(resumed.session_path.read_text())
    for key in ("log", "readings", "flags", "verification", "status", "codes"):
        assert a[key] == b[key], key
