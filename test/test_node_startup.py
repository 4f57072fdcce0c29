"""Issue 23 item 5: a node says in one line that it is ready -- its full name, mode and key
parameters -- and a configuration error is one clear line and exit 2, not a traceback."""

import subprocess
import sys
from pathlib import Path

from ros_harness import wait_until


def test_a_node_logs_one_ready_line_with_its_name_and_key_parameters(spawn):
    process = spawn(["hex-input-shaper", "--ros-args", "-r", "__ns:=/cell7", "-p", "shaper:=zv"])
    wait_until(lambda: "ready:" in process.output(), 60.0, what="the ready line")
    ready = [line for line in process.output().splitlines() if "ready:" in line]
    assert len(ready) == 1
    assert ready[0].endswith("ready: /cell7/input_shaper (shaper=zv, frequency_hz=5.0, damping=0.02)")


def test_a_configuration_error_is_one_line_and_exit_2(ros_env):
    plant = str(Path(sys.executable).parent / "hex-plant")
    done = subprocess.run([plant, "--ros-args", "-p", "mode:=bogus"], env=ros_env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["PlantNode: mode must be one of lockstep, realtime; got 'bogus'"]
    assert "Traceback" not in done.stdout + done.stderr


def test_the_nodes_start_without_scipy():
    """Every test graph and campaign cell starts these processes. scipy (through filterpy's
    package, the cut model's PDFs and Rotation) cost them 1.3 s of CPU a graph: 0.85 s the load
    predictor's import, now 0.23; the plant's 0.52, now 0.29; the robot state's 0.69, now 0.22.
    The planners imported scipy.optimize for a root that has a closed form: 0.3 s each."""
    modules = ["plant", "force_controller", "kinematics", "input_shaper", "load_predictor", "robot_state",
               "pass_planner", "sequence_planner"]
    probe = ("import sys\n" + "".join(f"import hex_control.ros.nodes.{m}\n" for m in modules)
             + "print(sorted({k.split('.')[0] for k in sys.modules} & {'scipy', 'filterpy', 'matplotlib'}))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stdout + done.stderr
