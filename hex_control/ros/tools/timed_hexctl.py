"""``hexctl`` timed: ``python -m hex_control.ros.tools.timed_hexctl ARGS`` runs the verb and
prints ``timing <start-up s> <verb s>`` as stderr's last line: the start-up (hexctl's modules
imported, from this module's first line) apart from the verb's own time (what the verb
imports on its way counts as the verb's: rclpy, for a verb that needs it). The caller times
the whole process beside it (the interpreter's own start and exit included)."""

import time

started = time.monotonic()

import sys  # noqa: E402

from hex_control.cli import main  # noqa: E402

if __name__ == "__main__":
    ready = time.monotonic()
    code = main(sys.argv[1:])
    print(f"timing {ready - started:.4f} {time.monotonic() - ready:.4f}", file=sys.stderr)
    sys.exit(code)
