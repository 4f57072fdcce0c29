"""`hexctl demo-load-predictor`: the load predictor over ROS 2, shortened."""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from hex_control.estimation import GaussMarkovModel


def test_demo_runs_and_reports(tmp_path, ros_env):
    """The interim main job, shortened: online identification, skill, PNG and JSON."""
    exe = Path(sys.executable).parent / "hexctl"
    result = subprocess.run([str(exe), "demo-load-predictor", "--samples", "800", "--output", str(tmp_path)],
                            env=ros_env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    # flow control keeps every queue below its depth, so nothing is lost at any machine load
    assert summary["samples_received"] == 800
    assert "predictions over ROS 2" in result.stdout and "skill vs persistence" in result.stdout
    assert summary["samples_lost_in_transport"] == 0  # sample_count continues across re-identification
    assert summary["identified_model"]["a"] == pytest.approx(0.95, abs=0.08)
    # SD of a sample mean of an AR(1) over the >= 500 samples of the last identification:
    # sqrt(Var dL (1 + a) / ((1 - a) n)) = 0.8 N for the demo model; allow 4 SD
    demo = GaussMarkovModel(0.95, 0.8, 1.5)
    sd_mean = math.sqrt(demo.stationary_variance * 1.95 / 0.05 / 500)
    assert summary["identified_model"]["mean_n"] == pytest.approx(40.0, abs=4 * sd_mean)
    # expected 0.223; the sampling SD of the skill over 400 samples is 0.03
    assert summary["skill_second_half"] > 0.10
    assert (tmp_path / "load_prediction.png").stat().st_size > 20_000
