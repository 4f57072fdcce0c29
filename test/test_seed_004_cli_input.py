"""Bad input to seed 004's verbs (issue 41 item 5): ``hexctl chatter`` and ``hexctl platform``
with a missing file, broken YAML, a document that is not a mapping, a missing section or
key, or a zero sampling period end in one line on stderr and exit 2, before any simulation;
and both verbs pin their BLAS libraries to one thread."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hex_control.cli import main
from hex_control.config import config_file

CHATTER = yaml.safe_load(config_file("milling/chatter.yaml").read_text())
PLATFORM = yaml.safe_load(config_file("mobile_platform/platform.yaml").read_text())


def _without(document: dict, section: str, key: str | None = None) -> dict:
    copy = yaml.safe_load(yaml.safe_dump(document))
    if key is None:
        del copy[section]
    else:
        del copy[section][key]
    return copy


def _with(document: dict, section: str, key: str | None, value) -> dict:
    copy = yaml.safe_load(yaml.safe_dump(document))
    if key is None:
        copy[section] = value
    else:
        copy[section][key] = value
    return copy


BAD = {
    "broken YAML": "tool: [1, 2\n  cut: {",
    "a list": "- 1\n- 2\n",
    "a number": "5\n",
    "empty": "",
}


def _run(capsys, argv) -> tuple[int, list[str]]:
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    return code, err


@pytest.mark.parametrize("verb", [["chatter"], ["platform", "compare"], ["platform", "tune"]])
def test_a_missing_file_is_named_as_given(verb, tmp_path, capsys):
    missing = tmp_path / "nonexistent.yaml"
    code, err = _run(capsys, [*verb, "--case", str(missing), "--output", str(tmp_path / "out")])
    assert code == 2 and len(err) == 1
    assert str(missing) in err[0] and "//" not in err[0]
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("verb, document", [(["chatter"], CHATTER), (["platform", "compare"], PLATFORM)])
@pytest.mark.parametrize("text", list(BAD.values()), ids=list(BAD))
def test_a_broken_or_non_mapping_file_is_one_line(verb, document, text, tmp_path, capsys):
    case = tmp_path / "case.yaml"
    case.write_text(text)
    code, err = _run(capsys, [*verb, "--case", str(case), "--output", str(tmp_path / "out")])
    assert code == 2 and len(err) == 1 and str(case) in err[0]


CHATTER_BAD = {
    "no tool section": _without(CHATTER, "tool"),
    "no depth": _without(CHATTER, "cut", "depth_m"),
    "zero step": _with(CHATTER, "simulation", "step_s", 0),
    "text for a number": _with(CHATTER, "cut", "teeth", "two"),
    "cut not a mapping": _with(CHATTER, "cut", None, [1, 2]),
    "band reversed": _with(CHATTER, "simulation", "chatter_band_hz", [990.0, 600.0]),
    "settle after the end": _with(CHATTER, "simulation", "settle_s", 5.0),
    "low above high": _with(CHATTER, "programmes", "low_rpm", 17000.0),
}
PLATFORM_BAD = {
    "no model section": _without(PLATFORM, "model"),
    "no wheel radius": _without(PLATFORM, "model", "wheel_radius_m"),
    "zero sampling period": _with(PLATFORM, "sampling_period_s", None, 0),
    "negative sampling period": _with(PLATFORM, "sampling_period_s", None, -0.01),
    "unknown plant key": _with(PLATFORM, "plant", "wings", 2.0),
    "curves not a list": _with(PLATFORM, "path", "curves", 3),
    "pid gains short": _with(PLATFORM, "two_pid", "speed", [1.0, 2.0]),
    "zero encoder counts": _with(PLATFORM, "encoder_counts_per_wheel_rev", None, 0),
    "no energy gain": _without(PLATFORM, "energy_index", "gain"),
}


@pytest.mark.parametrize("name", list(CHATTER_BAD))
def test_chatter_case_errors_are_one_line(name, tmp_path, capsys):
    case = tmp_path / "chatter.yaml"
    case.write_text(yaml.safe_dump(CHATTER_BAD[name]))
    code, err = _run(capsys, ["chatter", "--case", str(case), "--output", str(tmp_path / "out")])
    assert code == 2 and len(err) == 1 and str(case) in err[0], (name, err)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", list(PLATFORM_BAD))
def test_platform_case_errors_are_one_line(name, tmp_path, capsys):
    case = tmp_path / "platform.yaml"
    case.write_text(yaml.safe_dump(PLATFORM_BAD[name]))
    code, err = _run(capsys, ["platform", "compare", "--case", str(case), "--output", str(tmp_path / "out")])
    assert code == 2 and len(err) == 1 and str(case) in err[0], (name, err)
    assert not (tmp_path / "out").exists()


def test_both_verbs_pin_blas_to_one_thread(tmp_path, monkeypatch, capsys):
    """hexctl imports numpy before a verb runs, so OPENBLAS_NUM_THREADS set then is too late:
    the verbs set each loaded OpenBLAS to one thread themselves (seeds/blas.py)."""
    from hex_control.seeds import blas
    from hex_control.seeds.milling import study
    from hex_control.seeds.mobile_platform import study as platform_study

    seen = {}

    def fake_chatter(output, case, progress=None):
        seen["chatter"] = blas.blas_threads()
        raise ValueError("stopped after the BLAS check")

    def fake_platform(output, case, progress=None):
        seen["platform"] = blas.blas_threads()
        raise ValueError("stopped after the BLAS check")

    import numpy  # noqa: F401  (loaded, as in hexctl)

    for verb, module, fake in ((["chatter"], study, fake_chatter),
                               (["platform", "compare"], platform_study, fake_platform)):
        blas.limit_blas_threads(2)
        monkeypatch.setattr(module, "write_study", fake)
        assert main([*verb, "--output", str(tmp_path)]) == 2
    capsys.readouterr()
    assert seen["chatter"] and set(seen["chatter"].values()) == {1}
    assert seen["platform"] and set(seen["platform"].values()) == {1}
    blas.limit_blas_threads(1)


def test_the_shipped_cases_load(tmp_path):
    from hex_control.seeds.milling.case import ChatterCase
    from hex_control.seeds.mobile_platform.case import PlatformCase

    assert ChatterCase.from_yaml().cut.teeth == 2
    assert PlatformCase.from_yaml().period_s == pytest.approx(0.01)
    assert Path(config_file("milling/chatter.yaml")).is_file()
