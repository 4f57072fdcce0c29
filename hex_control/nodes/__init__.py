"""Thin rclpy adapters around the hex_control library: one module per node.

A node converts messages to library types, calls the library and converts back; it
holds parameters, timers and diagnostics, and no algorithm.
"""
