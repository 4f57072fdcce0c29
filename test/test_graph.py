"""The node graph as processes (hex_control.nodes.graph): a graph that does not start says
where each node waits before it is stopped."""

from diagnostic_msgs.msg import DiagnosticArray

from hex_control.nodes.graph import NodeGraph, graph_nodes
from ros_harness import wait_until


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
