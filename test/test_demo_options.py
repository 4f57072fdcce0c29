"""hexctl demo's run options (issue 37 item 7): stored when a run starts, taken up by
--resume (the original seed, not 0), a conflicting option refused; a graph that fails is
one line naming the node, its exit code and its log."""

import json

import pytest

from hex_control.cli import main
from hex_control.grinding.run_files import RUN_DEFAULTS, RUN_FILE, run_options, store_run_options
from hex_control.ros.app.grind_job import NodeDied


def test_a_fresh_run_takes_the_given_options_over_the_defaults():
    options = run_options({"seed": 7, "bead_length": 60, "namespace": "/cell3/"})
    assert options == {**RUN_DEFAULTS, "seed": 7, "bead_length": 60.0, "namespace": "/cell3"}
    assert isinstance(options["bead_length"], float)
    with pytest.raises(ValueError, match="not a namespace"):
        run_options({"namespace": "cell 3"})


def test_a_resumed_run_keeps_the_stored_options_and_refuses_a_conflicting_one(tmp_path):
    stored = {**RUN_DEFAULTS, "seed": 7, "deadline": 22.0, "bead_length": 60.0, "dulling": 0.25, "namespace": "/c3"}
    path = store_run_options(tmp_path, stored)
    assert path == tmp_path / RUN_FILE and json.loads(path.read_text()) == stored
    assert run_options({}, tmp_path) == stored  # not seed 0: the run's own
    assert run_options({"seed": 7, "bead_length": 60, "namespace": "/c3/"}, tmp_path) == stored  # the same, given
    with pytest.raises(ValueError, match=r"--seed 0 \(the run's: 7\).*--bead-length 300.0 \(the run's: 60.0\)"):
        run_options({"seed": 0, "bead_length": 300.0}, tmp_path)
    with pytest.raises(ValueError, match="--realtime True"):
        run_options({"realtime": True}, tmp_path)


def test_a_run_without_stored_options_is_resumed_only_with_its_seed_given(tmp_path):
    with pytest.raises(ValueError, match=f"{RUN_FILE} is missing.*--seed"):
        run_options({}, tmp_path)
    assert run_options({"seed": 4}, tmp_path)["seed"] == 4


def test_hexctl_demo_refuses_a_resume_with_a_conflicting_option_in_one_line(tmp_path, capsys):
    assert main(["demo", "--resume", str(tmp_path)]) == 2  # nothing to resume: said first
    assert "holds no unfinished job to resume" in capsys.readouterr().err
    (tmp_path / "jobs").mkdir()
    (tmp_path / "jobs" / "cut_off.jsonl").write_text('{"type": "goal"}\n{"type": "decision"}\n')
    store_run_options(tmp_path, {**RUN_DEFAULTS, "seed": 7})
    assert main(["demo", "--resume", str(tmp_path), "--seed", "3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--seed 3 (the run's: 7)" in err and "Traceback" not in err, err
    assert main(["demo", "--resume", str(tmp_path), "--jobs", "3"]) == 2
    assert "takes up one job" in capsys.readouterr().err


def test_a_node_that_died_is_one_line_with_its_exit_code_and_log(tmp_path):
    died = NodeDied("plant", -9, tmp_path / "logs/plant.log", "Traceback ...\nmore")
    assert died.one_line == f"node plant was killed by SIGKILL (exit code -9); its log: {tmp_path}/logs/plant.log"
    assert "more" in str(died)  # the log's tail, for a test that fails
    died.resume_dir = tmp_path
    assert died.one_line.endswith(f"; hexctl demo --resume {tmp_path} takes up its job") and "\n" not in died.one_line
    assert NodeDied("kinematics", 1, tmp_path / "k.log").one_line.startswith("node kinematics exited with code 1;")
