"""Bad input of ``hexctl unit-commitment`` (issue 41 items 3 and 5): every malformed fleet
file, a missing one and a day the fleet cannot serve end in one line on stderr naming
what is wrong and where, with exit 2 -- never a traceback."""

import numpy as np
import pytest

from hex_control.cli import main

TWO_UNITS = """fleet: two
units:
- {g_min_mw: 10.0, g_max_mw: 60.0, a1: 80.0, a2: 6.0, a3: 0.02, start_cost: [40.0, 70.0]}
- {g_min_mw: 5.0, g_max_mw: 40.0, a1: 20.0, a2: 7.5, a3: 0.03, start_cost: [10.0, 15.0]}
"""


def _run(argv, capsys) -> tuple[int, str]:
    """(exit code, stderr without the table's progress bar: the error line)."""
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith(("table ", "\r"))]
    return code, "".join(line + "\n" for line in lines)


@pytest.mark.parametrize(("text", "expected"), [
    ("", "an empty file"),
    ("units: 5\n", "'units' must be a non-empty list"),
    ("units: []\n", "'units' must be a non-empty list"),
    ("units:\n- {g_min_mw: 1, g_max_mw: 2, a1: 1, a3: 1, start_cost: [1]}\n", "machine 1 has no 'a2'"),
    ("units:\n- {g_min_mw: 1, g_max_mw: 2, a1: 1, a2: x, a3: 1, start_cost: [1]}\n", "a2 must be a number"),
    ("units:\n- {g_min_mw: 5, g_max_mw: 2, a1: 1, a2: 1, a3: 1, start_cost: [1]}\n", "machine 1: need 0 <= G_min"),
    ("units:\n- {g_min_mw: 1, g_max_mw: 2, a1: 1, a2: 1, a3: 1}\n", "start_cost must be a non-empty list"),
    ("units: [\n  {g_min_mw: 1\n", "not valid YAML or JSON at line"),
    ('{"units": [{"g_min_mw": 1,, "g_max_mw": 2}]}', "not valid YAML or JSON"),
    ("- just\n- a list\n", "must be a mapping"),
])
def test_a_malformed_fleet_file_is_one_line_naming_the_file_and_exit_2(tmp_path, capsys, text, expected):
    fleet = tmp_path / "fleet.yaml"
    fleet.write_text(text)
    code, err = _run(["unit-commitment", "table", "--fleet", str(fleet), "--output", str(tmp_path / "out")], capsys)
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert str(fleet) in err and expected in err, err


def test_a_missing_fleet_file_is_named_as_given(tmp_path, capsys):
    """The path was printed garbled as 'unit_commitment//tmp/...' (the shipped folder glued
    in front of an absolute path)."""
    missing = tmp_path / "nowhere" / "fleet.yaml"
    for given in (str(missing), "no_such_fleet.yaml"):
        code, err = _run(["unit-commitment", "day", "--fleet", given, "--output", str(tmp_path)], capsys)
        assert code == 2 and err.count("\n") == 1 and f"no fleet file '{given}'" in err, err
        assert "unit_commitment//" not in err


def test_a_day_the_fleet_cannot_serve_is_reported_as_demand_against_capacity(tmp_path, capsys):
    """One unit of 90..100 MW: the example day (peak at 85 % of capacity, trough 59 % of the
    peak) goes below what the unit can run at even with the store pumping; this was
    '55.18 MW is outside the table's 90..100 MW'. Over the capacity is the other side."""
    from hex_control.seeds.unit_commitment.day import deterministic_schedule
    from hex_control.seeds.unit_commitment.fleet import Fleet
    from hex_control.seeds.unit_commitment.storage import Storage
    from hex_control.seeds.unit_commitment.table import scheduling_table

    fleet_file = tmp_path / "one.yaml"
    fleet_file.write_text("units:\n- {g_min_mw: 90, g_max_mw: 100, a1: 1, a2: 1, a3: 0.01, start_cost: [1]}\n")
    code, err = _run(["unit-commitment", "day", "--fleet", str(fleet_file), "--output", str(tmp_path)], capsys)
    assert code == 2 and err.count("\n") == 1 and "the demand is under the least the fleet can run at" in err, err
    assert "in hour 3" in err and "90.0 MW" in err  # the trough, against the unit's G_min
    fleet = Fleet.from_yaml(fleet_file)
    table = scheduling_table(fleet, k=1, step_mw=5.0)
    with pytest.raises(ValueError, match=r"the demand is over the capacity: 110.0 MW in hour 1 against the fleet's "
                                         r"100.0 MW and the store's 5.0 MW"):
        deterministic_schedule(fleet, np.array([95.0, 110.0, 95.0]), Storage(-5.0, 5.0), table)


@pytest.mark.parametrize("argv", [
    ["table", "--k", "0"],
    ["table", "--step", "-5"],
    ["online", "--days", "1"],
    ["online", "--std", "-0.1", "--days", "2"],
    ["online", "--a", "1.5", "--days", "2"],
])
def test_bad_numbers_are_one_line_and_exit_2(tmp_path, capsys, argv):
    fleet = tmp_path / "two.yaml"
    fleet.write_text(TWO_UNITS)
    code, err = _run(["unit-commitment", *argv, "--fleet", str(fleet), "--output", str(tmp_path)], capsys)
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err


def test_a_corrupt_kept_table_is_one_line(tmp_path, capsys):
    fleet = tmp_path / "two.yaml"
    fleet.write_text(TWO_UNITS)
    (tmp_path / "table_two_k5_step100.json").write_text('{"rows": [{"total_mw": 1}]}')
    code, err = _run(["unit-commitment", "day", "--fleet", str(fleet), "--output", str(tmp_path)], capsys)
    assert code == 2 and "not a scheduling table" in err and err.count("\n") == 1, err


def test_eq_2_6_start_costs_in_a_fleet_file_are_tabulated_by_hours_down(tmp_path):
    """Eq. 2.6, CS = b1 (1 - b2 exp(-b3 d)), given instead of the table's CS(1..6): the fleet
    holds it at d = 1..6 hours down, and the day's DP charges those."""
    from hex_control.seeds.unit_commitment.fleet import Fleet, exponential_start_cost

    fleet_file = tmp_path / "exp.yaml"
    fleet_file.write_text("units:\n- {g_min_mw: 10, g_max_mw: 60, a1: 80, a2: 6, a3: 0.02,"
                          " start_cost_eq_2_6: {b1: 500, b2: 0.9, b3: 0.2}}\n")
    unit = Fleet.from_yaml(fleet_file).units[0]
    np.testing.assert_allclose(unit.start_cost, exponential_start_cost(500.0, 0.9, 0.2, np.arange(1, 7)))
    assert unit.starting_cost(1) == pytest.approx(500 * (1 - 0.9 * np.exp(-0.2)))
    assert unit.starting_cost(30) == unit.starting_cost(6)
    fleet_file.write_text("units:\n- {g_min_mw: 10, g_max_mw: 60, a1: 80, a2: 6, a3: 0.02,"
                          " start_cost_eq_2_6: {b1: 500, b2: 1.5, b3: 0.2}}\n")
    with pytest.raises(ValueError, match="0 <= b2 <= 1"):
        Fleet.from_yaml(fleet_file)
