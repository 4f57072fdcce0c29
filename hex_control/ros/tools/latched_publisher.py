"""A process that publishes one latched message and holds some volatile topics, for
``hexctl bench topic_tools``: ``python -m hex_control.ros.tools.latched_publisher TOPIC
MODULE CLASS INDEX EXTRA`` (the message's text fields say "bench"); prints ``ready:``."""

import importlib
import sys

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64


def main() -> None:
    topic, module, name, index, extra = sys.argv[1:6]
    cls = getattr(importlib.import_module(module), name)
    rclpy.init()
    node = rclpy.create_node(f"bench_publisher_{index}")
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    message = cls()
    for field in ("job_id", "data", "name"):
        if hasattr(message, field) and isinstance(getattr(message, field), str):
            setattr(message, field, "bench")
    node.create_publisher(cls, topic, latched).publish(message)
    for i in range(int(extra)):
        node.create_publisher(Float64, f"/bench/p{index}/topic_{i:02d}", 10)
    print("ready:", flush=True)
    rclpy.spin(node)


if __name__ == "__main__":
    main()
