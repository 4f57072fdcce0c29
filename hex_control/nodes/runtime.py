"""Entry-point plumbing shared by every node's ``main``."""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor


def run_node(node_class, args=None) -> int:
    """Init rclpy, spin ``node_class()`` until Ctrl-C / SIGTERM, shut down cleanly."""
    rclpy.init(args=sys.argv if args is None else args)
    node = None
    try:
        node = node_class()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:  # noqa: BLE001
        if rclpy.ok():
            raise
        # a signal shut the context down while the executor was building its wait set
        # ("context is not valid"): that is a normal stop, not an error
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
