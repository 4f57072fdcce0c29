"""hex_control.ros.infra.runtime: work done off the executor hands its result back at once."""

import threading
import time

import pytest


@pytest.mark.parametrize("executor_kind", ["events", "single"])
def test_background_work_wakes_its_node_without_a_poll(executor_kind, monkeypatch):
    """A pass plan or a policy solve ends on its own thread; ``then`` runs the node's
    callback on the node's executor (its thread, once) with no timer polling the future: the
    pass planner and the sequence planner hand over while the plant's clock stands."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    from hex_control.ros.infra.runtime import in_background, make_executor

    monkeypatch.setenv("HEX_EXECUTOR", executor_kind)
    context = Context()
    rclpy.init(context=context, signal_handler_options=rclpy.SignalHandlerOptions.NO)
    try:
        node = Node("background_wake", context=context)
        executor = make_executor(context=context)
        executor.add_node(node)
        release, ran = threading.Event(), []
        future = in_background(lambda: release.wait() and 42, then=(node, lambda: ran.append(
            threading.current_thread() is threading.main_thread())))
        executor.spin_once(timeout_sec=0.05)
        assert not ran and not future.done()  # nothing to hand over yet
        release.set()
        deadline = time.monotonic() + 60.0  # a bound for a broken wake, not a measure
        while not ran and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=1.0)
        assert ran == [True] and future.result() == 42
        executor.spin_once(timeout_sec=0.05)
        assert ran == [True]  # once
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()
