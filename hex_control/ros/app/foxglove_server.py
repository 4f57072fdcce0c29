"""``hexctl view``'s server: the Foxglove WebSocket server and the view's node
(:class:`hex_control.ros.app.foxglove_view.FoxgloveView`) spun in this process, the static
content logged again every second for clients that connect late."""

from __future__ import annotations

import math
import time

import foxglove
import rclpy
from rclpy.executors import SingleThreadedExecutor

from hex_control.ros.app.foxglove_view import FoxgloveView


def serve(host: str = "127.0.0.1", port: int = 8765, namespace: str = "", *, ready=None,
          duration_s: float = 0.0) -> int:
    """Serve the cell in this process's ROS domain until Ctrl-C (or for ``duration_s`` > 0 of
    wall time); ``ready(port)`` is called once the server listens (port 0: a free one)."""
    context = foxglove.Context()
    try:
        server = foxglove.start_server(name="hex_control", host=host, port=port, context=context)
    except RuntimeError as error:  # an address that does not resolve, a port in use: the user's input
        raise ValueError(f"cannot serve on {host}:{port}: {error}") from None
    rclpy_context = rclpy.Context()
    rclpy.init(context=rclpy_context)
    executor = SingleThreadedExecutor(context=rclpy_context)
    view = FoxgloveView(context, namespace, context=rclpy_context)
    executor.add_node(view)
    print(f"hexctl view: serving {namespace or 'the cell'} on ws://{host}:{server.port} (Foxglove: Open connection "
          f"-> Foxglove WebSocket); Ctrl-C ends it", flush=True)
    if ready is not None:
        ready(server.port)
    end = time.monotonic() + duration_s if duration_s > 0 else math.inf
    next_republish = 0.0
    try:
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
            if time.monotonic() >= next_republish:
                view.republish()
                next_republish = time.monotonic() + 1.0
    finally:
        executor.remove_node(view)
        view.destroy_node()
        executor.shutdown()
        rclpy_context.try_shutdown()
        server.stop()
    return 0
