"""`hexctl sdp`: solve from the shipped configuration, save the policy, plot the maps."""

import json

import numpy as np

from hex_control.cli import main
from hex_control.grinding.sdp import QUIT, Policy


def test_sdp_cli_with_lateness(tmp_path, capsys):
    assert main(["sdp", "--late", "30", "--output", str(tmp_path), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["quit_share"] > 0 and summary["grind_share"] > 0.3
    policy = Policy.load(tmp_path / "policy.npz")
    late_underground = policy.action[policy.time_s < 0][:, policy.material_mm > 0.02]
    assert np.all(late_underground == QUIT)  # the shipped charges are "expensive time" (5.5)
    for name in ("policy_map.png", "actions.png"):
        assert (tmp_path / name).stat().st_size > 20_000


def test_sdp_cli_refuses_a_bad_config(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("process: {bead_width_mm: -3}\n")
    assert main(["sdp", "--config", str(bad), "--output", str(tmp_path)]) == 2
    assert "bead_width_mm" in capsys.readouterr().err


def test_a_missing_config_file_is_one_line(tmp_path, capsys):
    assert main(["sdp", "--config", "no_such.yaml", "--output", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no_such.yaml" in err and "Traceback" not in err and err.count("\n") == 1
