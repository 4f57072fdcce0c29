"""hexctl record, play, bag: recordings in rosbag2's MCAP layout (hex_control/recording/,
hex_control/ros/tools/recorder.py), and hexctl bench."""

from __future__ import annotations

import time


def add_parsers(commands) -> None:
    record = commands.add_parser("record", help="record topics into rosbag2's MCAP layout (ros2 bag record)")
    record.add_argument("topics", nargs="*", help="topics to record")
    record.add_argument("-a", "--all", action="store_true", help="every topic, as it appears (hidden ones not)")
    record.add_argument("-o", "--output", default=None, help="recording directory (default: rosbag2_<time>)")
    record.add_argument("--duration", type=float, default=None, help="stop after this long (s); default Ctrl-C")
    play = commands.add_parser("play", help="publish a recording again (ros2 bag play)")
    play.add_argument("directory")
    play.add_argument("--rate", type=float, default=1.0, help="pace relative to the recording")
    play.add_argument("--topics", nargs="*", default=None, help="only these topics")
    play.add_argument("--wait", type=float, default=0.0, help="first wait this long for subscribers (s)")
    play.add_argument("-l", "--loop", action="store_true", help="play again from the start until Ctrl-C")
    play.add_argument("--clock", type=float, nargs="?", const=40.0, default=None, metavar="HZ",
                      help="publish the recorded time on /clock at HZ (default 40) for nodes on sim time")
    play.add_argument("-m", "--remap", nargs="+", default=None, metavar="FROM:=TO",
                      help="publish a recorded topic under another name, e.g. /plant/wrench:=/old/wrench")
    bag = commands.add_parser("bag", help="inspect a recording (ros2 bag info)")
    bag.add_subparsers(dest="verb", required=True).add_parser(
        "info", help="files, size, start, end, duration, and each topic's type and count").add_argument("directory")
    record.set_defaults(func=_record)
    play.set_defaults(func=_play)
    bag.set_defaults(func=_bag)


def add_bench_parser(commands) -> None:
    bench = commands.add_parser("bench", help="run benchmarks (ratios against in-process baselines)")
    bench.add_argument("cases", nargs="*", help="case names (default: all)")
    bench.add_argument("--quick", action="store_true", help="small sizes, for a smoke run")
    bench.set_defaults(func=_bench)


def _record(args) -> int:
    from hex_control.ros.tools.recorder import record

    return record(args.output or time.strftime("rosbag2_%Y_%m_%d-%H_%M_%S"), args.topics, args.all,
                  args.duration)


def _play(args) -> int:
    from hex_control.ros.tools.recorder import play

    return play(args.directory, args.rate, args.topics, args.wait, args.loop, clock_hz=args.clock, remaps=args.remap)


def _bag(args) -> int:
    return _bag_info(args.directory)


def _bag_info(directory: str) -> int:
    from hex_control.recording.bag import describe

    print(describe(directory))
    return 0


def _bench(args) -> int:
    from hex_control.bench import run_benchmarks

    return run_benchmarks(args.cases, quick=args.quick)
