"""``hexctl action list|send_goal``. send_goal prints the acceptance, each feedback (with
``--feedback``) and the result; Ctrl-C cancels the goal and waits for the server to say
so, as ``ros2 action send_goal`` does. Exit 0 when the goal succeeded, 1 when it was
rejected, aborted or canceled by the server, 2 when no server answered, 130 after a
Ctrl-C (the goal canceled, whatever its final status)."""

from __future__ import annotations

import rclpy
import yaml
from action_msgs.msg import GoalStatus
from rclpy.action import ActionClient, get_action_names_and_types

from hex_control.ros.infra.action_probe import ResponseProbe
from hex_control.ros.infra.messages import to_primitive
from hex_control.ros.tools.ros_cli.common import absolute, interface_message, settle_graph, spin_until

STATUS = {GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED", GoalStatus.STATUS_CANCELED: "CANCELED",
          GoalStatus.STATUS_ABORTED: "ABORTED"}


def action_list(show_types: bool, wait_s: float) -> int:
    """Every action once this verb's own discovery has settled (hexctl asks the daemon first)."""
    rclpy.init(args=None)
    try:
        node = rclpy.create_node("hexctl_action_list", start_parameter_services=False)
        settle_graph(node, wait_s)
        for name, types in sorted(get_action_names_and_types(node)):
            print(f"{name} [{', '.join(types)}]" if show_types else name)
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    return 0


def _print(title: str, msg) -> None:
    print(f"{title}:\n" + yaml.safe_dump(to_primitive(msg), sort_keys=False, default_flow_style=None).rstrip(),
          flush=True)


def send_goal(action: str, type_name: str, values: str, feedback: bool, timeout_s: float) -> int:
    cls, goal = interface_message(type_name, "action", "Goal", values)
    # our own Ctrl-C: the context must outlive it, to send the cancel
    rclpy.init(args=None, signal_handler_options=rclpy.SignalHandlerOptions.NO)
    node = rclpy.create_node("hexctl_action_send_goal", start_parameter_services=False)
    client = ActionClient(node, cls, absolute(action))
    try:
        spin_until(node, ResponseProbe(client), timeout_s, f"action server {absolute(action)}")
        print(f"Sending goal:\n{yaml.safe_dump(to_primitive(goal), sort_keys=False).rstrip()}", flush=True)
        sent = client.send_goal_async(goal, feedback_callback=(lambda m: _print("Feedback", m.feedback))
                                      if feedback else None)
        spin_until(node, sent.done, timeout_s, "the goal's acceptance")
        handle = sent.result()
        if not handle.accepted:
            print("Goal was rejected.")
            return 1
        result = handle.get_result_async()
        interrupted = False
        try:
            # printed inside the try: a Ctrl-C just after it (a script's, as the test's) cancels;
            # between it and the try it escaped with no cancel (seen once in CI)
            print(f"Goal accepted with ID: {bytes(handle.goal_id.uuid).hex()}", flush=True)
            while not result.done():
                rclpy.spin_once(node, timeout_sec=0.1)
        except KeyboardInterrupt:
            interrupted = True
            print("Canceling goal...", flush=True)
            cancel = handle.cancel_goal_async()
            spin_until(node, cancel.done, timeout_s, "the cancel's answer")
            spin_until(node, result.done, timeout_s, "the canceled goal's result")
        status = result.result().status
        _print("Result", result.result().result)
        print(f"Goal finished with status: {STATUS.get(status, status)}", flush=True)
        if interrupted:
            return 130  # the user's Ctrl-C, as every other verb: not the server's verdict
        return 0 if status == GoalStatus.STATUS_SUCCEEDED else 1
    finally:
        client.destroy()
        node.destroy_node()
        rclpy.try_shutdown()
