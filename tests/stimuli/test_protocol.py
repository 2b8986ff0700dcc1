import copy
import tomllib
from pathlib import Path

import pytest

from stimuli.protocol import (
    ProtocolError,
    describe_schema,
    load_protocol,
    parse_protocol,
    pixel_deg,
)

PROTOCOLS = Path(__file__).parents[2] / "protocols"


def raw(study):
    return tomllib.loads((PROTOCOLS / f"{study}.toml").read_text())


@pytest.mark.parametrize("study", ["yoshida2008", "spencer1995", "luidolt2020"])
def test_shipped_protocols_are_valid(study):
    protocol = load_protocol(PROTOCOLS / f"{study}.toml")
    assert protocol.study == study
    assert len(protocol.sha256) == 64


def test_yoshida_values_are_the_papers():
    p = load_protocol(PROTOCOLS / "yoshida2008.toml")
    # Yoshida 2008 §3
    assert p["glare"]["gaussian"]["levels_cd_m2"] == [220, 1165, 2110, 3055, 4000, 7000]
    assert p["glare"]["vos"]["levels_cd_m2"] == [220, 1480, 2740, 4000, 7000, 10000]
    assert p["glare"]["gaussian"]["sigma_deg"] == 0.34
    assert p["display"]["max_cd_m2"] == 433.0 and p["display"]["bit_depth"] == 10
    # 20.8" 4:3 2048 × 1536 at 1 m: pitch 0.2064 mm → 0.011824° per pixel (hand calculation)
    assert pixel_deg(p) == pytest.approx(0.0118244, rel=1e-5)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda d: d["stimulus"].update(disk_degg=0.3), r"stimulus\.disk_degg: unknown key"),
        (
            lambda d: d["stimulus"].update(disk_deg=-0.3),
            r"stimulus\.disk_deg = -0\.3: must be float, in \[0\.01, 10\] deg",
        ),
        (
            lambda d: d["stimulus"].update(target_start_cd_m2=[100.0, 500.0]),
            r"stimulus\.target_start_cd_m2\[1\] = 500\.0: above what the display shows",
        ),
        (
            lambda d: d["glare"].update(l_dmax_cd_m2=500.0),
            r"glare\.l_dmax_cd_m2 = 500\.0: above what the display shows",
        ),
        (
            lambda d: d["glare"]["gaussian"].pop("sigma_deg"),
            r"glare\.gaussian\.sigma_deg: missing",
        ),
        (lambda d: d["glare"].pop("vos"), r"\[glare\.vos\]: missing table"),
        (
            lambda d: d["display"].update(bit_depth=9),
            r"display\.bit_depth = 9: must be int, one of 8, 10, 12, 16",
        ),
        (
            lambda d: d["display"].update(max_cd_m2="bright"),
            r"display\.max_cd_m2 = 'bright': must be a number",
        ),
        (
            lambda d: d["glare"]["vos"].update(labels=["a", "b"]),
            r"glare\.vos: 2 labels for 6 levels_cd_m2",
        ),
        (
            lambda d: d["display"].update(pixel_pitch_mm=0.2),
            "give exactly one of diagonal_in and pixel_pitch_mm",
        ),
        (
            lambda d: d["study"].update(name="kakimoto2004"),
            r"study\.name = 'kakimoto2004': must be one of",
        ),
    ],
)
def test_bad_protocols_are_refused_with_the_key_named(edit, match):
    data = copy.deepcopy(raw("yoshida2008"))
    edit(data)
    with pytest.raises(ProtocolError, match=match):
        parse_protocol(data, source="test.toml")


def test_every_problem_is_reported_at_once():
    data = copy.deepcopy(raw("spencer1995"))
    data["stimulus"]["window_pxx"] = 300
    data["glare"]["peak_fraction"] = 2.0
    data["trials"]["neither"] = "maybe"
    with pytest.raises(ProtocolError) as caught:
        parse_protocol(data)
    assert len(caught.value.problems) == 3


def test_a_file_that_is_not_toml_is_named(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[study\nname = 1")
    with pytest.raises(ProtocolError, match=r"broken\.toml: 1 problem(?s:.*)not valid TOML"):
        load_protocol(path)
    with pytest.raises(FileNotFoundError, match="no protocol file"):
        load_protocol(tmp_path / "missing.toml")


def test_the_hash_follows_the_content():
    a = parse_protocol(raw("luidolt2020"))
    changed = raw("luidolt2020")
    changed["questionnaire"]["comments"] = False
    assert parse_protocol(changed).sha256 != a.sha256
    assert parse_protocol(raw("luidolt2020")).sha256 == a.sha256


def test_schema_documents_every_key():
    rows = describe_schema("yoshida2008")
    keys = {r[0] for r in rows}
    assert "glare.gaussian.sigma_deg" in keys and "display.bit_depth" in keys
    assert all(r[4] for r in rows)  # every key has a description


def test_questions_that_do_not_fit_the_session_csv_are_refused():
    text = (PROTOCOLS / "yoshida2008.toml").read_text()
    five = text.replace(
        '"Are the sizes of reference and target disks the same?",',
        '"Are the sizes of reference and target disks the same?", "Q4?", "Q5?",',
    )
    with pytest.raises(ProtocolError, match=r"questionnaire.questions has 5 entries: must be"):
        parse_protocol(tomllib.loads(five))
    two = text.replace('  "Do you see a bright ring (a.k.a. Mach-band)?",\n', "")
    with pytest.raises(ProtocolError, match="must be none or three"):
        parse_protocol(tomllib.loads(two))
