"""``hexctl``: the project's command line (demo, topic tools, benchmarks)."""

from __future__ import annotations

import argparse
import os
import signal
import sys

from hex_control.cli import cell, grinding, kinematics, recording, ros_verbs, seeds, shaping, unit_commitment, view
from hex_control.cli.cell import MACHINES

__all__ = ["MACHINES", "main"]


def _parser() -> argparse.ArgumentParser:
    """The commands in the order of ``hexctl --help``; each module adds its own, each
    command's ``func`` runs it."""
    parser = argparse.ArgumentParser(prog="hexctl", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    cell.add_parsers(commands)
    kinematics.add_parsers(commands)
    grinding.add_parsers(commands)
    shaping.add_parsers(commands)
    unit_commitment.add_parsers(commands)
    seeds.add_parsers(commands)
    recording.add_parsers(commands)
    recording.add_bench_parser(commands)
    ros_verbs.add_parsers(commands)
    view.add_parsers(commands)
    return parser


_terminated_by = None  # the signal that asked hexctl to stop, once one has


def _exit_on_sigterm(signum, frame):
    # as SystemExit, so that `with` blocks unwind: `hexctl demo` stops the node processes
    # it started (they run in sessions of their own) instead of leaving them running
    global _terminated_by
    _terminated_by = signum
    raise SystemExit(128 + signum)


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    try:
        return args.func(args)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # `hexctl ... | head`: the reader has what it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as exc:
        from hex_control.ros.tools.ros_cli.common import VerbError

        if isinstance(exc, VerbError):
            if exc.code != 130:
                print(f"hexctl: {exc}", file=sys.stderr)
            return exc.code
        if _terminated_by is not None:
            # the SystemExit was raised inside a callback from rclpy's C++ (e.g. building a
            # message), which turns it into another error: still the signal's exit
            return 128 + _terminated_by
        if isinstance(exc, (ValueError, FileNotFoundError)):  # the user's input: one line, no traceback
            print(f"hexctl: {exc}", file=sys.stderr)
            return 2
        raise

