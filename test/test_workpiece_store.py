"""The part kept across restarts (hex_control.plant.workpiece_store)."""

import numpy as np
import pytest

from hex_control.grinding.contour import weld_bead
from hex_control.plant.workpiece_store import StoredWorkpiece, load_workpiece, save_workpiece


def test_a_stored_part_comes_back_as_it_was_scanned(tmp_path):
    path = tmp_path / "jobs" / "workpiece.json"
    assert load_workpiece(path) is None  # nothing kept yet: the plant grinds a fresh bead
    part = StoredWorkpiece("job-1", 3, weld_bead(60.0, 0.8, seed=2), {"pass_index": 2, "measured_cut_depth_mm": 0.1})
    save_workpiece(path, part)
    again = load_workpiece(path)
    assert (again.job_id, again.passes, again.last_result) == ("job-1", 3, part.last_result)
    for name in ("x_mm", "z_mm", "parent_mm"):
        assert np.array_equal(getattr(again.contour, name), getattr(part.contour, name))  # to the last bit
    save_workpiece(path, StoredWorkpiece("job-1", 4, part.contour))  # replaced whole, nothing left beside it
    assert load_workpiece(path).passes == 4 and sorted(p.name for p in path.parent.iterdir()) == ["workpiece.json"]
    assert load_workpiece(path).started is None


def test_the_pass_under_way_is_kept_until_it_is_scanned(tmp_path):
    """Written when a pass begins: a plant restarted before its scan knows which plan ran
    across the restart (plant.pass_verdict)."""
    path = tmp_path / "workpiece.json"
    save_workpiece(path, StoredWorkpiece("job-1", 2, weld_bead(60.0, 0.8, seed=2), started=("job-1", 2, 21.65)))
    assert load_workpiece(path).started == ("job-1", 2, 21.65)
    path.write_text(path.read_text().replace("21.65]", "21.65, 7]"))
    with pytest.raises(ValueError, match="not a stored workpiece"):
        load_workpiece(path)


def test_a_damaged_file_is_named_not_taken_up(tmp_path):
    path = tmp_path / "workpiece.json"
    path.write_text('{"job_id": "j", "passes": 1, "x_mm": [0, 1], "z_mm": [0]}')
    with pytest.raises(ValueError, match="workpiece.json is not a stored workpiece"):
        load_workpiece(path)
    with pytest.raises(ValueError):
        StoredWorkpiece("j", -1, weld_bead(10.0, 0.5))
