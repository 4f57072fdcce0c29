"""``hexctl pass``: plans a pass on a test bead, writes the plot, the contour and a summary."""

import json

from hex_control.cli import main
from hex_control.grinding.contour import Contour


def test_pass_cli_writes_png_csv_and_json(tmp_path, capsys):
    out = tmp_path / "pass"
    assert main(["pass", "--length", "60", "--depth", "0.3", "--k1-error", "0.2", "--output", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["planned_depth_mm"] == 0.3 and summary["reason"] == ""
    assert abs(summary["simulated_volume_mm3"] / summary["wanted_volume_mm3"] - 1) < 0.01
    errors = summary["executed_volume_error"]
    assert abs(errors["executed, same coefficients"]) < 0.03 and -0.3 < errors["executed, K1 +20%"] < -0.08
    assert (out / "pass.png").stat().st_size > 10_000
    final = Contour.from_csv(out / "final_contour.csv")
    assert final.length_mm == 60.0
