"""`hexctl shaper design|plot`."""

import json
import subprocess
import sys

import pytest

from hex_control.cli import main


def test_design_prints_the_sequence_as_json(capsys):
    assert main(["shaper", "design", "--type", "zvd", "--frequency", "2.0", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["amplitudes"] == [0.25, 0.5, 0.25] and summary["delay_s"] == 0.5
    assert abs(summary["insensitivity_5pct"] - 0.287) < 0.001
    assert abs(summary["worst_vibration_in_band"] - 0.2061) < 0.001  # cos^2(0.35 pi) at +-30 %


def test_optimized_design_and_plots(tmp_path, capsys):
    assert main(["shaper", "design", "--type", "optimized", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)  # the progress bar goes to stderr
    assert summary["criterion"] <= 0.025 and summary["delay_s"] <= 1.5
    assert summary["worst_vibration_in_band"] < 0.15
    assert main(["shaper", "plot", "--output", str(tmp_path)]) == 0
    for name in ("sensitivity.png", "step_responses.png"):
        assert (tmp_path / name).stat().st_size > 20_000


def test_unknown_shaper_is_refused_with_the_known_ones(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["shaper", "design", "--type", "posicast"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'posicast'" in err and "zvd" in err and "3hump_ei" in err  # listed from SHAPERS


def test_sigterm_inside_a_native_callback_still_exits_with_its_code(monkeypatch):
    """CI, with two CPU burners: SIGTERM's SystemExit raised while rclpy's C++ built a
    message came out as pybind11's TypeError, and `hexctl demo` exited 1, not 143."""
    import signal

    from hex_control import cli

    def interrupted(args):
        try:
            cli._exit_on_sigterm(signal.SIGTERM, None)
        except SystemExit as exc:  # what pybind11 does to an exception it cannot pass on
            raise TypeError("Unable to convert function return value to a Python type!") from exc

    monkeypatch.setattr(cli.shaping, "_shaper", interrupted)
    monkeypatch.setattr(cli, "_terminated_by", None)
    previous = signal.getsignal(signal.SIGTERM)
    try:
        assert main(["shaper", "design", "--type", "zvd"]) == 128 + signal.SIGTERM
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_the_cli_names_every_shaper_without_importing_them():
    """hexctl starts without numpy (issue 40: an echo under two CPU burners within 2 s): the
    shaper verbs' choices are names kept beside the shapers, and must be theirs."""
    from hex_control.cli.shaping import SHAPER_NAMES
    from hex_control.shaping.shapers import SHAPERS

    assert SHAPER_NAMES == tuple(SHAPERS)
    run = subprocess.run([sys.executable, "-c", "import sys; from hex_control import cli; cli._parser(); "
                          "print('numpy' in sys.modules)"], capture_output=True, text=True, timeout=60)
    assert run.stdout.strip() == "False", run.stdout + run.stderr
