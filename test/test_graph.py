"""The node graph as processes (hex_control.ros.app.graph): a graph that does not start says
where each node waits before it is stopped; a run's job directory is its own."""

import sys
from pathlib import Path

import yaml
from diagnostic_msgs.msg import DiagnosticArray

from hex_control.config import config_file, node_parameters
from hex_control.ros.app.graph import RESTART_PARTICIPANT_IDS, NodeGraph, graph_nodes
from hex_control.ros.app.node_forks import ForkedNode
from ros_harness import NodeProcess, forked_node_module, wait_until


def test_a_dump_writes_every_threads_traceback_into_the_nodes_log_and_the_node_runs_on(ros_env, ros, tmp_path):
    kinematics = [spec for spec in graph_nodes(tmp_path / "jobs") if spec.name == "kinematics"]
    graph = NodeGraph(kinematics, tmp_path / "logs", env=ros_env)
    graph.start()
    try:
        diagnostics = ros.collect(DiagnosticArray, "/diagnostics", 10)
        # a diagnostics report comes from its executor: the node is past its start-up, spinning
        wait_until(lambda: any(s.name == "/kinematics" for m in list(diagnostics) for s in m.status), 60.0,
                   what="the kinematics node's diagnostics")
        assert graph.dump_tracebacks() == []
        log = graph.log_tail("kinematics", 400)
        assert "(most recent call first):" in log and "spin_until_stopped" in log, log
        assert not graph.dead(), graph.log_tail("kinematics")
    finally:
        codes = graph.stop()
    assert codes == {"kinematics": 0}


def test_forked_nodes_report_their_ends_and_outlive_their_server(ros_env, ros, tmp_path):
    """Issue 39 (the suite's CPU; a graph starts on 2.2 CPU s instead of 3.8): the graph's
    nodes are forked from one server that imported them (node_forks.py). A forked node logs
    as its own process, its exit code comes back (a SIGKILL's -9, a Ctrl-C's 0), a restart
    forks it again, as a DDS participant id of its own (not its dead predecessor's), and one
    whose server died is still followed: running until it is gone. The process's next graph
    is forked from the same server, unless it died."""
    import os
    import signal

    from hex_control.ros.app.node_forks import UNKNOWN_EXIT, ForkedNode

    kinematics = [spec for spec in graph_nodes(tmp_path / "jobs") if spec.name == "kinematics"]
    graph = NodeGraph(kinematics, tmp_path / "logs", env=ros_env)
    graph.start()
    try:
        first = graph.processes["kinematics"]
        assert isinstance(first, ForkedNode) and first.pid != graph.forks.server.pid
        wait_until(lambda: "ready: /kinematics" in graph.log_tail("kinematics"), 60.0, what="the forked node")
        graph.kill("kinematics")
        assert first.returncode == -signal.SIGKILL
        graph.start("kinematics")
        again = graph.processes["kinematics"]
        assert again.pid != first.pid and again.poll() is None
        wait_until(lambda: "ready: /kinematics" in graph.log_tail("kinematics"), 60.0, what="the node forked again")
        probe = ros.node("probe")
        participant_ids = wait_until(lambda: {  # a GUID's bytes 8-11: its participant id, little-endian
            int.from_bytes(bytes(info.endpoint_gid)[8:12], "little")
            for info in probe.get_publishers_info_by_topic("/diagnostics") if info.node_name == "kinematics"}
            - {0} or None, 30.0, what="the restarted node's publisher")
        assert participant_ids == {RESTART_PARTICIPANT_IDS[0]}
        graph.forks.server.kill()  # the nodes are in sessions of their own: they run on
        graph.forks.server.wait()
        wait_until(lambda: graph.forks.server_gone, 10.0, what="the server's end read")
        assert again.poll() is None
        os.kill(again.pid, signal.SIGKILL)
        assert again.wait(timeout=10.0) == UNKNOWN_EXIT
    finally:
        graph.stop()
    assert graph.forks is None  # let go with its graph
    graph.start()
    try:
        second = graph.forks.server
        wait_until(lambda: "ready: /kinematics" in graph.log_tail("kinematics"), 60.0, what="a second server's node")
    finally:
        codes = graph.stop()
    assert codes == {"kinematics": 0}
    graph.start()  # a Ctrl-C the moment a node is forked stops it (it was lost, and SIGKILL came 10 s later)
    assert graph.forks.server is second and second.poll() is None
    assert graph.stop()["kinematics"] in (0, -signal.SIGINT)
    # another graph in another domain, in another test (pytest names it in the environment):
    # the same server; one whose imports could differ (OpenBLAS's threads) gets its own, and
    # the server no graph uses any longer ends
    for env, shared in (({**ros_env, "ROS_DOMAIN_ID": "101", "PYTEST_CURRENT_TEST": "another"}, True),
                        ({**ros_env, "OPENBLAS_NUM_THREADS": "2"}, False)):
        other = NodeGraph(kinematics, tmp_path / "other_logs", env=env)
        other.start()
        try:
            assert (other.forks.server is second) is shared
        finally:
            other.stop()
    assert second.poll() is not None


def test_a_tests_node_is_forked_when_it_is_one_of_the_graphs():
    python = sys.executable
    nodes = "hex_control.ros.nodes"
    assert forked_node_module(["hex-plant", "--ros-args"], {}) == (f"{nodes}.plant", ["--ros-args"])
    assert forked_node_module(["hex-load-predictor"], {}) == (f"{nodes}.load_predictor", [])
    assert forked_node_module([python, "-P", "-m", f"{nodes}.robot_state", "--ros-args", "-r", "a:=b"], {}) \
        == (f"{nodes}.robot_state", ["--ros-args", "-r", "a:=b"])
    assert forked_node_module(["hex-plant"], {"HEX_NODE_FORKS": "0"}) is None  # as a graph's
    assert forked_node_module(["hex-synthetic-load"], {}) is None  # no graph runs it: the server lacks it
    assert forked_node_module(["hexctl", "demo"], {}) is None
    assert forked_node_module([python, "-m", "hex_control.cli", "view"], {}) is None
    # what the fork would not do as the command line says: run other code, take other options
    assert forked_node_module([python, "-c", "print()", "-m", f"{nodes}.plant"], {}) is None
    assert forked_node_module([python, "-X", "dev", "-m", f"{nodes}.plant"], {}) is None
    assert forked_node_module(["bash", "-m", f"{nodes}.plant"], {}) is None


def test_a_forked_test_node_takes_its_command_lines_arguments_and_stops_on_sigint(ros_env, tmp_path):
    node = NodeProcess([sys.executable, "-P", "-m", "hex_control.ros.nodes.input_shaper", "--ros-args",
                        "-r", "__node:=forked_shaper"], ros_env, tmp_path / "shaper.log")
    try:
        assert isinstance(node.process, ForkedNode)
        wait_until(lambda: "ready: /forked_shaper" in node.output(), 60.0, what="the node's ready line")
    finally:
        code = node.stop()
    assert code == 0 and not node.alive()


def test_a_new_run_does_not_take_up_an_earlier_runs_unfinished_job(tmp_path):
    """The sequence planner resumes any unfinished job in its job directory: a demo run
    again into the same output after one was cut off moves that log aside and starts clean;
    finished logs stay where they are."""
    from hex_control.grinding.run_files import fresh_job_dir

    jobs = tmp_path / "jobs"
    jobs.mkdir()
    (jobs / "done.jsonl").write_text('{"type": "goal"}\n{"type": "end", "reason": "done"}\n')
    assert fresh_job_dir(tmp_path) == jobs and (jobs / "done.jsonl").exists()  # nothing to resume
    (jobs / "cut_off.jsonl").write_text('{"type": "goal"}\n{"type": "decision"}\n')
    assert fresh_job_dir(tmp_path) == jobs and not jobs.exists()
    assert sorted(p.name for p in (tmp_path / "jobs-1").iterdir()) == ["cut_off.jsonl", "done.jsonl"]
    jobs.mkdir()
    (jobs / "again.jsonl").write_text('{"type": "goal"}\n')
    fresh_job_dir(tmp_path)
    assert (tmp_path / "jobs-2" / "again.jsonl").exists()


def test_a_demo_keeps_to_a_domain_of_its_own_unless_one_is_set():
    """Issue 23 item 4: two demos (or a demo and a user's graph) on one host must not meet."""
    import os

    from hex_control.ros.app.demo import use_private_domain

    environment = {}
    assert use_private_domain(environment)
    assert 1 <= int(environment["ROS_DOMAIN_ID"]) <= 101 and int(environment["ROS_DOMAIN_ID"]) == 1 + os.getpid() % 101
    chosen = {"ROS_DOMAIN_ID": "17"}
    assert not use_private_domain(chosen) and chosen == {"ROS_DOMAIN_ID": "17"}


def _remaps(spec, name: str) -> list[str]:
    arguments = list(spec.arguments)
    return [arguments[i + 1].split(":=", 1)[1] for i, a in enumerate(arguments[:-1])
            if a == "-r" and arguments[i + 1].startswith(f"{name}:=")]


def test_every_node_of_a_namespaced_graph_lands_in_the_cell():
    """Issue 37 item 7: the first __ns remapping on a command line wins, so each node has one:
    the cell's, or <cell>/load_predictor for a predictor (before, a predictor's came after the
    cell's and lost: /cell3/pass, with none of its parameter file's values); the sim clock is
    the cell's wherever the node sits."""
    for namespace in ("/cell3", ""):
        specs = {spec.name: spec for spec in graph_nodes(Path("/tmp/jobs"), namespace=namespace)}
        assert "load_predictor_pass" in specs
        for name, spec in specs.items():
            expected = f"{namespace}/load_predictor" if name.startswith("load_predictor") else namespace
            assert _remaps(spec, "__ns") == ([expected] if expected else []), (name, spec.arguments)
            assert _remaps(spec, "/clock") == [f"{namespace}/clock"], (name, spec.arguments)
        assert _remaps(specs["load_predictor_pass"], "__node") == ["pass"]


def test_every_parameter_file_of_the_graph_applies_in_any_namespace_and_names_topics_relatively():
    """A section ``/**/<node>`` matches the node under any namespace; a value starting with '/'
    (an absolute topic such as /grinding/pass_result) would reach outside the cell. The
    predictors sit under <cell>/load_predictor: their relative inputs resolve in the cell
    (``input_namespace: parent``), test_load_predictor_node.py runs one so."""
    files = {spec.arguments[i + 1] for spec in graph_nodes(Path("/tmp/jobs"), namespace="/c")
             for i, a in enumerate(spec.arguments[:-1]) if a == "--params-file"}
    assert {Path(f).name for f in files} >= {"plant.yaml", "force_controller.yaml", "load_predictor.yaml"}
    for file in files:
        document = yaml.safe_load(Path(file).read_text())
        for section, body in document.items():
            assert section.startswith("/**/"), (file, section)
            absolute = {k: v for k, v in body["ros__parameters"].items() if isinstance(v, str) and v.startswith("/")}
            assert not absolute, (file, section, absolute)
    for name in ("pass", "force"):
        predictor = node_parameters("load_predictor.yaml", f"load_predictor/{name}")
        assert predictor["input_namespace"] == "parent" and not predictor["input_topic"].startswith(("/", "~"))


#: inputs of the graph that no node of it feeds: hand use, where the first publisher heard owns them
HAND_INPUTS = {("input_shaper", "sample_owner")}


def effective_parameters(spec) -> dict:
    """A graph node's parameters as it starts: its PARAMETERS' defaults, then its sections of
    the --params-file(s), then the -p values on its command line (as strings)."""
    import importlib

    module = importlib.import_module(f"hex_control.ros.nodes.{spec.module}")
    values = {name: parameter.default for name, parameter in module.PARAMETERS.items()}
    arguments = list(spec.arguments)
    node = {"load_predictor_pass": "load_predictor/pass", "load_predictor_force": "load_predictor/force"}.get(
        spec.name, spec.name)
    for i, argument in enumerate(arguments[:-1]):
        if argument == "--params-file":
            section = yaml.safe_load(Path(arguments[i + 1]).read_text()).get(f"/**/{node}", {})
            values.update(section.get("ros__parameters", {}))
        elif argument == "-p":
            name, _, value = arguments[i + 1].partition(":=")
            values[name] = value
    return values


def test_every_command_input_of_the_graph_names_its_source_relative_to_the_cell():
    """Issue 37 item 3 in the graph the project starts: every ``*_owner`` (and a predictor's
    ``input_owner``) names the node it takes commands from, not '' (the first heard), except
    the inputs no node of the graph feeds (jogging by hand); relative names, so that a cell
    under a namespace obeys its own nodes."""
    owners = {}
    for spec in graph_nodes(Path("/tmp/jobs"), namespace="/cell3"):
        for name, value in effective_parameters(spec).items():
            if name.endswith("_owner"):
                owners[(spec.name, name)] = value
    assert ("plant", "force_command_owner") in owners and ("load_predictor_pass", "input_owner") in owners
    unnamed = {key for key, value in owners.items() if not str(value).strip()}
    assert unnamed == HAND_INPUTS, owners
    absolute = {key: value for key, value in owners.items() if str(value).strip().startswith("/")}
    assert not absolute, absolute


def test_the_robot_state_node_describes_the_machine_the_plant_runs():
    """Issue 40 item 1: robot_state is in every graph, in the cell, with the plant's machine
    file and bead frame, so its frames are the plant's."""
    machine = str(config_file("machines/pru3_feed.yaml"))
    for namespace in ("", "/cell5"):
        specs = {spec.name: spec for spec in graph_nodes(Path("/tmp/jobs"), machine_file=machine,
                                                         namespace=namespace)}
        robot, plant = effective_parameters(specs["robot_state"]), effective_parameters(specs["plant"])
        assert robot["machine_file"] == plant["machine_file"] == machine
        assert robot["pass_planner_config"] == plant["pass_planner_config"]
        assert _remaps(specs["robot_state"], "__ns") == ([namespace] if namespace else [])
    default = effective_parameters({s.name: s for s in graph_nodes(Path("/tmp/jobs"))}["robot_state"])
    assert default["machine_file"] == effective_parameters(
        {s.name: s for s in graph_nodes(Path("/tmp/jobs"))}["plant"])["machine_file"]
