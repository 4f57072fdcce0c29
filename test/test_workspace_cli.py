"""`hexctl workspace`: maps, slices and a roll sweep as PNGs and JSON."""

import json

from hex_control.cli import main


def test_workspace_report(tmp_path, capsys):
    code = main(["workspace", "--rolls", "0", "20", "--sweep", "0", "20", "10", "--heights", "-2100",
                 "--sectors", "800", "--output", str(tmp_path), "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert [m["roll_deg"] for m in summary["maps"]] == [0.0, 20.0]
    assert [s["roll_deg"] for s in summary["sweep"]] == [0.0, 10.0, 20.0]
    level, rolled = summary["maps"]
    assert level["limiting_share"]["II"] == 0.0 < rolled["limiting_share"]["II"]
    assert rolled["center_mm"][1] > level["center_mm"][1]
    for name in ("workspace_roll_0.png", "workspace_roll_20.png", "slices.png", "roll_sweep.png"):
        assert (tmp_path / name).stat().st_size > 10_000


def test_workspace_refuses_a_3pru(capsys):
    assert main(["workspace", "--machine", "machines/pru3.yaml"]) == 2
    assert "machine 'pru3_seed001' (machines/pru3.yaml) has none" in capsys.readouterr().err
