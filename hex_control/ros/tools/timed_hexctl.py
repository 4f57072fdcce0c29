"""``hexctl`` timed: ``python -m hex_control.ros.tools.timed_hexctl ARGS`` runs the verb and
prints ``timing <start-up s> <verb s>`` as stderr's last line, the start-up (Python, rclpy
and the verb's modules imported) apart from the verb's own time."""

import time

started = time.monotonic()

import sys  # noqa: E402

import rclpy  # noqa: E402, F401  (imported here so that its import counts as start-up)
import yaml  # noqa: E402, F401

from hex_control.cli import main  # noqa: E402
from hex_control.ros.tools.ros_cli import topic  # noqa: E402, F401

if __name__ == "__main__":
    ready = time.monotonic()
    code = main(sys.argv[1:])
    print(f"timing {ready - started:.4f} {time.monotonic() - ready:.4f}", file=sys.stderr)
    sys.exit(code)
