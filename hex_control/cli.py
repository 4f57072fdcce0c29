"""``hexctl``: the project's command line (demo, topic tools, benchmarks)."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time

from hex_control.shaping.shapers import SHAPERS

MACHINES = {"hexapod": "machines/nist_ingersoll.yaml", "pru3": "machines/pru3_feed.yaml"}  # hexctl demo --machine


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hexctl", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)

    # the run's options default to None here (hex_control.ros.app.grind_job.RUN_DEFAULTS fills
    # them): --resume must tell an option given from one left out
    demo = commands.add_parser("demo", help="the main job: the whole hierarchy grinds a weld bead on the plant",
                               epilog="exit codes: 0 the job(s) ended as the policy intended, without burn; 1 not; "
                                      "2 a bad option or input; 3 the graph failed (a node died, its loop stood)")
    demo.add_argument("--output", default="output/demo", help="report directory")
    demo.add_argument("--deadline", type=float, default=None, help="the job's deadline (s; default 100)")
    demo.add_argument("--seed", type=int, default=None, help="process-variation seed of the (first) job (default 0)")
    demo.add_argument("--jobs", type=int, default=None, help="seeded jobs to run one after the other (statistics)")
    demo.add_argument("--realtime", action="store_true", default=None,
                      help="plant in real time (watch it live) instead of lock-step")
    demo.add_argument("--real-time-factor", type=float, default=None, help="with --realtime: sim speed vs wall (1)")
    demo.add_argument("--bead-length", type=float, default=None, help="bead length (mm; default 300)")
    demo.add_argument("--bead-height", type=float, default=None, help="bead height (mm; default 1)")
    demo.add_argument("--dulling", type=float, default=None, help="K1 growth per pass (a disk that dulls; default 0)")
    demo.add_argument("--machine", choices=sorted(MACHINES), default=None,
                      help="the NIST-like hexapod (default), or the 3-PRU head on a feed stage")
    demo.add_argument("--restart-planner-after", type=int, default=None, metavar="K",
                      help="fault drill: kill the sequence planner after pass K and restart it")
    demo.add_argument("--machine-host", default="", help="command prefix that puts the machine-side nodes on "
                      "another host, e.g. 'ip netns exec hexA' (scripts/two_hosts.sh)")
    demo.add_argument("--machine-peers", default="", help="ROS_STATIC_PEERS for the machine-side nodes")
    demo.add_argument("--no-record", action="store_true", help="do not record the messages (recording/: "
                      "rosbag2's MCAP layout, for Foxglove, PlotJuggler, hexctl play)")
    demo.add_argument("--resume", metavar="DIR", default=None,
                      help="take up the unfinished job of a run cut off in DIR (its --output): the planner resumes it "
                           "from DIR/jobs, the plant the part as last scanned, with the options the run started with "
                           "(DIR/run.json: its seed ...; one given that differs is an error); without it every run "
                           "starts afresh")
    demo.add_argument("--namespace", default=None, help="run the cell under this namespace, e.g. /cell2 (one "
                      "namespace holds one cell; cells side by side in a domain do not meet)")

    predictor = commands.add_parser("demo-load-predictor", help="the Kalman load predictor alone over ROS 2")
    predictor.add_argument("--output", default="output/load_predictor", help="report directory")
    predictor.add_argument("--samples", type=int, default=2000, help="load samples to publish")
    predictor.add_argument("--rate", type=float, default=200.0, help="sample rate (Hz)")
    predictor.add_argument("--seed", type=int, default=7)

    campaign = commands.add_parser(
        "campaign", help="seeded jobs as independent cells in parallel (local processes or Ray), and their statistics",
        epilog="the same seeds give the same statistics.json as hexctl demo --jobs N, whatever the workers or backend. "
               "exit codes: 0 every job ran and ended as its policy intended, without burn; 1 not; 2 a bad option; "
               "3 a job's graph failed (counted in campaign.json; the others' statistics are written)")
    campaign.add_argument("--jobs", type=int, default=20, help="seeded jobs, seeds --seed .. --seed + N - 1 (20)")
    campaign.add_argument("--seed", type=int, default=None, help="the first job's seed (default 0)")
    campaign.add_argument("--output", default="output/campaign", help="report directory (job_<seed>/ inside)")
    campaign.add_argument("--workers", type=int, default=None,
                          help="local worker processes, each running one cell at a time (default: the CPU count)")
    campaign.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                          help="run on Ray, one task per job: a cluster's address (ray://head:10001, auto), or none "
                               "for a local Ray (with --workers CPUs)")
    campaign.add_argument("--deadline", type=float, default=None, help="each job's deadline (s; default 100)")
    campaign.add_argument("--bead-length", type=float, default=None, help="bead length (mm; default 300)")
    campaign.add_argument("--bead-height", type=float, default=None, help="bead height (mm; default 1)")
    campaign.add_argument("--dulling", type=float, default=None, help="K1 growth per pass (default 0)")
    campaign.add_argument("--machine", choices=sorted(MACHINES), default=None, help="hexapod (default) or pru3")
    campaign.add_argument("--no-record", action="store_true", help="do not record each job's messages")
    campaign.add_argument("--job-timeout", type=float, default=1800.0, help="wall seconds a job may take (1800)")
    campaign.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")

    stats = commands.add_parser("job-stats", help="statistics over report directories of hexctl demo")
    stats.add_argument("directories", nargs="+", help="report directories (a job's, or one with job_* inside)")
    stats.add_argument("--output", default="", help="also write the statistics here (JSON)")

    workspace = commands.add_parser("workspace", help="workspace maps, slices and roll sweep (PNG, JSON)")
    workspace.add_argument("--machine", default="machines/nist_ingersoll.yaml",
                           help="machine YAML (path, or a name under config/)")
    workspace.add_argument("--rolls", type=float, nargs="*", default=[0.0, 10.0, 20.0],
                           help="rolls (deg) of the 3-D maps")
    workspace.add_argument("--sweep", type=float, nargs=3, default=[0.0, 30.0, 1.0],
                           metavar=("START", "STOP", "STEP"), help="roll sweep (deg), inclusive")
    workspace.add_argument("--heights", type=float, nargs="*", default=[-2600.0, -2100.0, -1600.0],
                           help="cross-section heights (mm); the seed's are -2.6, -2.1, -1.6 m")
    workspace.add_argument("--sectors", type=int, default=1250, help="sectors per map")
    workspace.add_argument("--eps", type=float, default=1.0, help="boundary precision (mm)")
    workspace.add_argument("--output", default="output/workspace", help="report directory")
    workspace.add_argument("--json", action="store_true", help="print the summary as JSON")

    sdp = commands.add_parser("sdp", help="solve the grinding-sequence SDP and plot the policy")
    sdp.add_argument("--config", default="sequence_planner.yaml",
                     help="planner YAML (process, charges, grid, cut_model); path or name under config/")
    sdp.add_argument("--late", type=float, default=None, help="override grid.late_horizon_s (s)")
    sdp.add_argument("--burn", type=float, default=None, help="override process.burn_coefficient")
    sdp.add_argument("--output", default="output/sdp", help="report directory")
    sdp.add_argument("--json", action="store_true", help="print the summary as JSON")

    grind = commands.add_parser("pass", help="plan one grinding pass on a bead and plot it (seed 002 ch. 6)")
    grind.add_argument("--config", default="pass_planner.yaml", help="pass planner YAML; path or name under config/")
    grind.add_argument("--contour", default=None, help="CSV with x_mm, z_mm[, parent_mm]; default: a test bead")
    grind.add_argument("--length", type=float, default=150.0, help="test bead length (mm)")
    grind.add_argument("--height", type=float, default=3.0, help="test bead height (mm)")
    grind.add_argument("--ripple", type=float, default=0.15, help="test bead ripple RMS (mm)")
    grind.add_argument("--seed", type=int, default=3, help="test bead seed")
    grind.add_argument("--depth", type=float, default=0.4, help="mean cut depth delta (mm)")
    grind.add_argument("--feed", type=float, default=10.0, help="feed speed (mm/s)")
    grind.add_argument("--control", choices=["height", "relaxed_angle"], default=None, help="override the config")
    grind.add_argument("--k1-error", type=float, nargs="*", default=[0.15],
                       help="also execute the plan with K1 off by these fractions")
    grind.add_argument("--output", default="output/pass", help="report directory")
    grind.add_argument("--json", action="store_true", help="print the summary as JSON")

    shaper = commands.add_parser("shaper", help="design and plot input shapers (seed 003)")
    shaper_verbs = shaper.add_subparsers(dest="verb", required=True)
    shaper_design = shaper_verbs.add_parser("design", help="print the impulse sequence of a shaper")
    shaper_design.add_argument("--type", default="zvd", choices=[*SHAPERS, "optimized"],
                               help="a closed-form shaper, or optimized (the seed's evolution design)")
    shaper_design.add_argument("--frequency", type=float, default=1.0, help="design frequency (Hz)")
    shaper_design.add_argument("--damping", type=float, default=0.0)
    shaper_design.add_argument("--vtol", type=float, default=0.05, help="vibration tolerance of EI shapers")
    shaper_design.add_argument("--frequencies", type=float, nargs="*", default=[0.85, 1.0, 1.5],
                               help="optimized: frequencies to cancel (Hz)")
    shaper_design.add_argument("--impulses", type=int, default=5, help="optimized: number of impulses")
    shaper_design.add_argument("--max-delay", type=float, default=1.5, help="optimized: longest delay (s)")
    shaper_design.add_argument("--seed", type=int, default=1)
    shaper_design.add_argument("--band", type=float, nargs=2, default=[0.7, 1.3],
                               help="report the worst V over this band of frequency ratios")
    shaper_design.add_argument("--json", action="store_true")
    shaper_plot = shaper_verbs.add_parser("plot", help="sensitivity curves and step responses (PNG)")
    shaper_plot.add_argument("--types", nargs="*", default=["zv", "zvd", "ei", "2hump_ei", "3hump_ei"],
                             choices=list(SHAPERS))
    shaper_plot.add_argument("--frequency", type=float, default=5.0, help="design frequency (Hz)")
    shaper_plot.add_argument("--damping", type=float, default=0.02)
    shaper_plot.add_argument("--mode", type=float, default=None, help="mode frequency of the step responses (Hz)")
    shaper_plot.add_argument("--output", default="output/shaper")

    commitment = commands.add_parser("unit-commitment", help="seed 000 part 2: scheduling table, off-line day, "
                                     "on-line stochastic scheduling of a power system (PNG, JSON)")
    commitment_verbs = commitment.add_subparsers(dest="verb", required=True)
    for verb, text in (("table", "build the scheduling table (section 4)"),
                       ("day", "schedule the example day off-line (sections 3, 5)"),
                       ("online", "schedule days of random demand on-line, both load models (sections 6, 7)")):
        job = commitment_verbs.add_parser(verb, help=text)
        job.add_argument("--fleet", default="fleet_41.yaml", help="fleet file (config/unit_commitment/ or a path)")
        job.add_argument("--k", type=int, default=5, help="candidates per level")
        job.add_argument("--step", type=float, default=100.0, help="nominal level step of rule 4.1 (MW)")
        job.add_argument("--output", default="output/unit_commitment")
        if verb == "day":
            job.add_argument("--milp", action="store_true", help="also solve the day as a MILP (the peer)")
        if verb == "online":
            job.add_argument("--days", type=int, default=40, help="simulated days per load model")
            job.add_argument("--history-days", type=int, default=80, help="days measured to identify a, W, V")
            job.add_argument("--std", type=float, default=0.0142, help="relative std of the fluctuation")
            job.add_argument("--a", type=float, default=0.8, help="Gauss-Markov coefficient per hour")
            job.add_argument("--seed", type=int, default=0)
            job.add_argument("--unbounded-store", action="store_true",
                             help="the store's energy unbounded (its rates kept), as in the 7-machine test")

    chatter = commands.add_parser("chatter", help="seed 004 section 3: chatter in slender ball-end milling, "
                                  "spindle-speed programmes and stability lobes (PNG, JSON)")
    chatter.add_argument("--case", default="chatter.yaml", help="case file (config/milling/ or a path)")
    chatter.add_argument("--output", default="output/chatter")

    platform = commands.add_parser("platform", help="seed 004 section 4: the two-wheeled platform, energy-index "
                                   "control against two PIDs (PNG, JSON)")
    platform_verbs = platform.add_subparsers(dest="verb", required=True)
    for verb, text in (("compare", "both controllers on Fig. 7's and Fig. 10's paths, as modelled and loaded"),
                       ("tune", "tune both controllers by the same ITAE minimization (prints the gains)")):
        job = platform_verbs.add_parser(verb, help=text)
        job.add_argument("--case", default="platform.yaml", help="case file (config/mobile_platform/ or a path)")
        job.add_argument("--output", default="output/platform")
        if verb == "tune":
            job.add_argument("--iterations-per-gain", type=int, default=40, help="Nelder-Mead iterations per gain")

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

    bench = commands.add_parser("bench", help="run benchmarks (ratios against in-process baselines)")
    bench.add_argument("cases", nargs="*", help="case names (default: all)")
    bench.add_argument("--quick", action="store_true", help="small sizes, for a smoke run")

    topic = commands.add_parser("topic", help="inspect topics (ros2 topic stand-in)")
    verbs = topic.add_subparsers(dest="verb", required=True)
    lst = verbs.add_parser("list", help="list topics")
    lst.add_argument("-t", "--show-types", action="store_true", help="types and endpoint counts")
    lst.add_argument("--include-hidden", action="store_true", help="also hidden topics (an action's _action/...)")
    lst.add_argument("--wait", type=float, default=GRAPH_WAIT_S, help=GRAPH_WAIT_HELP)
    topic_info = verbs.add_parser("info", help="a topic's type and endpoints (-v: each with its node and QoS)")
    topic_info.add_argument("topic")
    topic_info.add_argument("-v", "--verbose", action="store_true")
    topic_info.add_argument("--wait", type=float, default=GRAPH_WAIT_S, help=GRAPH_WAIT_HELP)
    echo = verbs.add_parser("echo", help="print messages of a topic as YAML")
    echo.add_argument("topic")
    echo.add_argument("--once", action="store_true")
    echo.add_argument("--count", type=int, default=0, help="stop after N messages (0 = never)")
    echo.add_argument("--field", default="", help="dotted field path to print, e.g. wrench.force")
    echo.add_argument("--timeout", type=float, default=10.0,
                      help="wait this long for the first message, discovery included (s); none by then: exit 2")
    hz = verbs.add_parser("hz", help="print the receive rate of a topic")
    hz.add_argument("topic")
    hz.add_argument("--window", type=int, default=1000, help="messages in the statistics window")
    hz.add_argument("--duration", type=float, default=0.0, help="stop after this many s (0 = never)")
    hz.add_argument("--timeout", type=float, default=10.0, help="wait for the topic and its first message (s)")
    pub = verbs.add_parser("pub", help="publish a message given as YAML")
    pub.add_argument("topic")
    pub.add_argument("type", help="message type, e.g. std_msgs/msg/Float64")
    pub.add_argument("values", nargs="?", default="", help="YAML mapping of fields, e.g. '{data: 1.5}'")
    pub.add_argument("-r", "--rate", type=float, default=1.0, help="publish rate (Hz)")
    pub.add_argument("-t", "--times", type=int, default=0, help="publish N times (0 = until Ctrl-C)")
    pub.add_argument("-1", "--once", action="store_true", help="publish once")
    pub.add_argument("--wait", type=float, default=2.0, help="wait for a subscriber first (s)")
    for verb in (echo, pub):
        verb.add_argument("--qos-durability", choices=["transient_local", "volatile"], default=None,
                          help="default: the publishers' on echo (latched ones too), volatile on pub")
        verb.add_argument("--qos-reliability", choices=["best_effort", "reliable"], default=None)
        verb.add_argument("--qos-depth", type=int, default=None, help="history depth")
    _ros_verbs(commands)
    return parser


#: list and info verbs wait until discovery has settled (hex_control.ros.tools.ros_cli.common.settle_graph),
#: at most this long (s)
GRAPH_WAIT_S = 10.0
GRAPH_WAIT_HELP = "wait at most this long (s) for discovery to settle (it ends sooner when the graph stands still)"


def _ros_verbs(commands) -> None:
    """hexctl node / param / service / action: ros2cli's verbs (hex_control/ros/tools/ros_cli/)."""
    node = commands.add_parser("node", help="nodes of the graph (ros2 node stand-in)").add_subparsers(
        dest="verb", required=True)
    node.add_parser("list", help="list nodes").add_argument("--wait", type=float, default=GRAPH_WAIT_S,
                                                            help=GRAPH_WAIT_HELP)
    info = node.add_parser("info", help="a node's topics, services and actions")
    info.add_argument("node", help="full name, e.g. /plant")
    info.add_argument("--include-hidden", action="store_true", help="also hidden ones (an action's _action/...)")
    info.add_argument("--wait", type=float, default=GRAPH_WAIT_S, help=GRAPH_WAIT_HELP)
    param = commands.add_parser("param", help="parameters of running nodes (ros2 param stand-in)").add_subparsers(
        dest="verb", required=True)
    for verb, text in (("list", "list a node's parameters"), ("get", "print a parameter"),
                       ("set", "set a parameter (a YAML value)"),
                       ("describe", "type, description, range, choices of one or more parameters"),
                       ("dump", "all parameters as a parameter file"), ("load", "set the parameters of a file")):
        job = param.add_parser(verb, help=text)
        job.add_argument("node", help="full name, e.g. /force_controller")
        if verb in ("get", "set"):
            job.add_argument("name")
        if verb == "describe":
            job.add_argument("names", nargs="+")
        if verb == "load":
            job.add_argument("file", help="a parameter file (hexctl param dump's, or a launch one)")
            job.add_argument("--no-use-wildcard", action="store_true", help="ignore the file's /** section")
        if verb == "set":
            job.add_argument("value")
        job.add_argument("--timeout", type=float, default=10.0, help="wait for the node (s)")
    service = commands.add_parser("service", help="services (ros2 service stand-in)").add_subparsers(
        dest="verb", required=True)
    _list_verb(service, "services")
    call = service.add_parser("call", help="call a service with a YAML request")
    call.add_argument("service")
    call.add_argument("type", help="e.g. hex_control_msgs/srv/InverseKinematics")
    call.add_argument("values", nargs="?", default="", help="YAML mapping of the request's fields")
    call.add_argument("--timeout", type=float, default=10.0, help="wait for the service and its answer (s)")
    call.add_argument("--no-resend", action="store_true", help="send once (for a service that must not run twice)")
    action = commands.add_parser("action", help="actions (ros2 action stand-in)").add_subparsers(
        dest="verb", required=True)
    _list_verb(action, "actions")
    goal = action.add_parser("send_goal", help="send a goal; Ctrl-C cancels it")
    goal.add_argument("action", help="e.g. /sequence_planner/grind_bead")
    goal.add_argument("type", help="e.g. hex_control_msgs/action/GrindBead")
    goal.add_argument("values", nargs="?", default="", help="YAML mapping of the goal's fields")
    goal.add_argument("-f", "--feedback", action="store_true", help="print the feedback")
    goal.add_argument("--timeout", type=float, default=30.0, help="wait for the server and its answers (s)")
    interface = commands.add_parser("interface", help="interface definitions (ros2 interface stand-in)") \
        .add_subparsers(dest="verb", required=True)
    interface.add_parser("show", help="a message's, service's or action's definition, nested types expanded") \
        .add_argument("type", help="e.g. geometry_msgs/msg/WrenchStamped, hex_control_msgs/action/GrindBead")


def _list_verb(verbs, what: str) -> None:
    listing = verbs.add_parser("list", help=f"list {what}")
    listing.add_argument("-t", "--show-types", action="store_true")
    if what == "services":
        listing.add_argument("--include-hidden", action="store_true", help="also an action's _action/... services")
    listing.add_argument("--wait", type=float, default=GRAPH_WAIT_S, help=GRAPH_WAIT_HELP)


def _ros_verb(args) -> int:
    if args.command == "topic":
        from hex_control.ros.tools.ros_cli import topic

        if args.verb == "list":
            return topic.topic_list(args.show_types, args.wait, args.include_hidden)
        if args.verb == "info":
            return topic.topic_info(args.topic, args.verbose, args.wait)
        if args.verb == "echo":
            return topic.topic_echo(args.topic, args.once, args.count, args.field, args.timeout,
                                    args.qos_durability, args.qos_reliability, args.qos_depth)
        if args.verb == "hz":
            return topic.topic_hz(args.topic, args.window, args.duration, args.timeout)
        return topic.topic_pub(args.topic, args.type, args.values, args.rate, 1 if args.once else args.times,
                               args.wait, args.qos_durability, args.qos_reliability, args.qos_depth)
    if args.command == "node":
        from hex_control.ros.tools.ros_cli import node

        return node.node_list(args.wait) if args.verb == "list" else \
            node.node_info(args.node, args.wait, args.include_hidden)
    if args.command == "param":
        from hex_control.ros.tools.ros_cli import param

        if args.verb in ("list", "dump"):
            return getattr(param, f"param_{args.verb}")(args.node, args.timeout)
        if args.verb == "set":
            return param.param_set(args.node, args.name, args.value, args.timeout)
        if args.verb == "describe":
            return param.param_describe(args.node, args.names, args.timeout)
        if args.verb == "load":
            return param.param_load(args.node, args.file, args.timeout, not args.no_use_wildcard)
        return param.param_get(args.node, args.name, args.timeout)
    if args.command == "service":
        from hex_control.ros.tools.ros_cli import service

        if args.verb == "list":
            return service.service_list(args.show_types, args.wait, args.include_hidden)
        return service.service_call(args.service, args.type, args.values, args.timeout, not args.no_resend)
    if args.command == "interface":
        from hex_control.ros.tools.ros_cli.interface import interface_show

        return interface_show(args.type)
    from hex_control.ros.tools.ros_cli import action

    if args.verb == "list":
        return action.action_list(args.show_types, args.wait)
    return action.send_goal(args.action, args.type, args.values, args.feedback, args.timeout)


def _job_stats(args) -> int:
    import json
    from pathlib import Path

    from hex_control.config import config_file
    from hex_control.grinding.config import load_planner_config
    from hex_control.grinding.job_report import job_statistics, load_job_summaries

    summaries = load_job_summaries(args.directories)
    charges = load_planner_config(config_file("sequence_planner.yaml"))[1]
    text = json.dumps(job_statistics(summaries, charges.deadline.tolerance_mm), indent=2)
    print(text)
    if args.output:
        Path(args.output).write_text(text + "\n")
    return 0


def _campaign(args) -> int:
    """``hexctl campaign``: N seeded cells on local worker processes or Ray, the statistics
    of ``hexctl demo --jobs N`` over those that ran (hex_control/campaign/)."""
    import json

    from hex_control.campaign import campaign_record, gather, run_campaign, seeded_jobs, write_campaign
    from hex_control.campaign.executors import ProcessExecutor, RayExecutor
    from hex_control.grinding.job_report import job_statistics
    from hex_control.ros.app.campaign_cell import campaign_settings, grind_cell, tolerance_mm
    from hex_control.ros.app.grind_job import RUN_DEFAULTS, job_line, run_options

    given = {name: getattr(args, name, None) for name in RUN_DEFAULTS if getattr(args, name, None) is not None}
    options = run_options(given)
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be at least 1, not {args.workers}")
    executor = (RayExecutor(args.ray or None, num_cpus=args.workers) if args.ray is not None
                else ProcessExecutor(args.workers))
    settings = campaign_settings(options, MACHINES[options["machine"]], record=not args.no_record,
                                 timeout_s=args.job_timeout)
    jobs = seeded_jobs(options["seed"], args.jobs, args.output, settings)
    where = f"Ray at {args.ray}" if args.ray else "a local Ray" if args.ray is not None else \
        f"{executor.workers} local worker processes"
    print(f"campaign: {len(jobs)} jobs, seeds {jobs[0].seed}..{jobs[-1].seed}, on {where}; each cell in a ROS domain "
          "of its own", flush=True)
    start = time.monotonic()
    outcomes = run_campaign(jobs, grind_cell, executor, progress=not args.no_progress,
                            on_outcome=lambda o: job_line(o.seed, o.summary) if o.ok else f"job {o.seed}: FAILED: "
                                                                                         f"{o.error}")
    wall = time.monotonic() - start
    stats = gather(outcomes, lambda summaries: job_statistics(summaries, tolerance_mm()))
    record = campaign_record(outcomes, executor.name, executor.workers, wall)
    write_campaign(args.output, outcomes, stats, record)
    if stats is not None:
        print(json.dumps(stats, indent=2))
    ran = [o for o in outcomes if o.ok]
    print(f"campaign: {len(ran)} of {len(outcomes)} jobs ran, {record['failed']} failed"
          f"{' (seeds ' + ', '.join(str(f['seed']) for f in record['failures']) + ')' if record['failed'] else ''}; "
          f"{wall:.0f} s wall for {record['job_wall_s_sum']:.0f} s of job wall time; report: {args.output}")
    if record["failed"]:
        return 3
    return 0 if all(o.summary["ended_as_intended"] and not o.summary["burn"] for o in ran) else 1


def _workspace(args) -> int:
    import json
    import math
    from pathlib import Path

    import numpy as np
    from tqdm import tqdm

    from hex_control.config import config_path
    from hex_control.kinematics import load_machine
    from hex_control.kinematics.report import workspace_report

    geometry, document = load_machine(config_path(args.machine))
    if not geometry.maps_workspace:
        raise ValueError(f"workspace maps are for machines with a 6-DOF workspace, as the hexapod of seed 000; "
                         f"machine {geometry.name!r} ({args.machine}) has none")
    cube = document.get("workspace", {}).get("search_cube_mm")
    if cube is None:
        raise ValueError(f"{args.machine} has no workspace.search_cube_mm section")
    start, stop, step = args.sweep
    sweep = np.arange(start, stop + step / 2, step) if step > 0 else np.array([])
    n_phi = max(3, round(math.sqrt(args.sectors / 2)))
    with tqdm(total=len(args.rolls) + len(sweep), desc="workspace", unit="map") as bar:
        summary = workspace_report(geometry, cube, Path(args.output), args.rolls, sweep.tolist(), args.heights,
                                   2 * n_phi, n_phi, args.eps, progress=lambda: bar.update(1))
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for entry in summary["maps"]:
            shares = ", ".join(f"{k} {v:.0%}" for k, v in entry["limiting_share"].items() if v)
            print(f"roll {entry['roll_deg']:5.1f} deg: volume {entry['volume_m3']:.3f} m^3, "
                  f"centre {entry['center_mm']} mm, limited by {shares}")
        print(f"wrote {args.output}/ (workspace_roll_*.png, slices.png, roll_sweep.png, summary.json)")
    return 0


def _sdp(args) -> int:
    import dataclasses
    import json
    from pathlib import Path

    import numpy as np
    from tqdm import tqdm

    from hex_control.grinding.config import load_planner_config
    from hex_control.grinding.plots import plot_action_map, plot_policy_map
    from hex_control.grinding.sdp import GRIND, QUIT, solve

    process, charges, grid, cut_model = load_planner_config(args.config)
    if args.late is not None:
        grid = dataclasses.replace(grid, late_horizon_s=args.late)
    if args.burn is not None:
        process = dataclasses.replace(process, burn_coefficient=args.burn)
    output = Path(args.output)
    output.mkdir(parents=True, exist_ok=True)
    with tqdm(total=len(grid.time_s) - 1, desc="SDP stages", unit="stage") as bar:
        policy = solve(process, charges, grid, cut_model, progress=bar.update)
    policy.save(output / "policy.npz")
    plot_policy_map(output / "policy_map.png", policy)
    plot_action_map(output / "actions.png", policy)
    grinding = policy.action == GRIND
    summary = {
        "states": [len(policy.time_s), len(policy.material_mm)],
        "feeds_mm_s": policy.metadata["feeds_mm_s"],
        "grind_share": float(grinding.mean()), "quit_share": float((policy.action == QUIT).mean()),
        "max_cut_mm": float(np.nanmax(policy.cut_mm)),
        "penalty_at": {f"t={t:g}s,X={x:g}mm": policy.expected_penalty(t, x)
                       for t, x in ((grid.horizon_s, 1.0), (grid.horizon_s / 2, 1.0), (20.0, 0.5))},
    }
    (output / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2) if args.json else
          f"solved {summary['states'][0]} x {summary['states'][1]} states; max cut {summary['max_cut_mm']:.3f} mm; "
          f"wrote {output}/policy.npz, policy_map.png, actions.png, summary.json")
    return 0


def _pass(args) -> int:
    import dataclasses
    import json
    from pathlib import Path

    from hex_control.grinding.config import load_pass_planner_config
    from hex_control.grinding.contour import Contour, weld_bead
    from hex_control.grinding.pass_plan import execute_plan, plan_pass
    from hex_control.grinding.pass_plots import plot_pass

    config = load_pass_planner_config(args.config)
    contour = Contour.from_csv(args.contour) if args.contour else \
        weld_bead(args.length, args.height, ripple_mm=args.ripple, seed=args.seed)
    model = config.model
    plan = plan_pass(contour, model, args.depth, args.feed, args.control or config.control, config.step_mm,
                     gains=config.gains if args.control in (None, config.control) else None)
    executed = {"executed, same coefficients": execute_plan(contour, model, plan)}
    for error in args.k1_error:
        process = dataclasses.replace(model.process,
                                      specific_energy_j_mm3=model.process.specific_energy_j_mm3 * (1 + error))
        executed[f"executed, K1 {error:+.0%}"] = execute_plan(contour, dataclasses.replace(model, process=process),
                                                             plan)
    output = Path(args.output)
    output.mkdir(parents=True, exist_ok=True)
    plot_pass(output / "pass.png", contour, plan, {name: sim.final for name, sim in executed.items()})
    plan.simulation.final.to_csv(output / "final_contour.csv")
    wanted = plan.target.removed_mm3
    summary = {**plan.summary(), "executed_volume_error": {
        name: sim.removed_mm3 / wanted - 1 for name, sim in executed.items()}}
    (output / "summary.json").write_text(json.dumps(summary, indent=2))
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"planned {plan.planned_depth_mm:.3f} mm at {plan.feed_mm_s:g} mm/s: {summary['duration_s']:.1f} s, "
              f"peak force {summary['peak_force_n']:.1f} N, peak power {summary['peak_power_w']:.0f} W; "
              f"simulated volume {plan.simulation.removed_mm3:.1f} of {wanted:.1f} mm^3")
        for name, error in summary["executed_volume_error"].items():
            print(f"  {name}: volume error {error:+.1%}")
        if plan.reason:
            print(f"  {plan.reason}")
        print(f"wrote {output}/pass.png, final_contour.csv, summary.json")
    return 0


def _shaper(args) -> int:
    import json
    from pathlib import Path

    import numpy as np

    from hex_control.shaping.shapers import design
    from hex_control.shaping.vibration import insensitivity, residual_vibration

    if args.verb == "plot":
        from hex_control.shaping.plots import plot_sensitivity, plot_step_responses

        output = Path(args.output)
        output.mkdir(parents=True, exist_ok=True)
        shapers = {kind: design(kind, args.frequency, args.damping) for kind in args.types}
        plot_sensitivity(output / "sensitivity.png", shapers, args.frequency, args.damping)
        plot_step_responses(output / "step_responses.png", shapers, args.mode or args.frequency, args.damping)
        print(f"wrote {output}/sensitivity.png and step_responses.png")
        return 0
    if args.type == "optimized":
        from tqdm import tqdm

        from hex_control.shaping.optimize import DesignProblem, optimize

        problem = DesignProblem(frequencies_hz=tuple(args.frequencies), impulses=args.impulses,
                                max_delay_s=args.max_delay)
        with tqdm(desc="evolution", unit="generation") as bar:
            result = optimize(problem, seed=args.seed, progress=lambda: bar.update(1))
        shaper, extra = result.shaper, {"criterion": result.criterion}
    else:
        shaper = design(args.type, args.frequency, args.damping, args.vtol)
        extra = {"insensitivity_5pct": insensitivity(shaper, args.frequency, args.damping)}
    band = np.linspace(args.band[0], args.band[1], 201) * (args.frequency if args.type != "optimized" else 1.0)
    summary = {"type": args.type, "amplitudes": shaper.amplitudes.tolist(), "times_s": shaper.times_s.tolist(),
               "delay_s": shaper.delay_s, "worst_vibration_in_band": float(residual_vibration(shaper, band,
                                                                                                   args.damping).max()),
               **extra}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for a, t in zip(shaper.amplitudes, shaper.times_s):
            print(f"A = {a:.4f}   t = {t:.5f} s")
        print(f"delay {shaper.delay_s:.4f} s; worst V over the band {summary['worst_vibration_in_band']:.4f}; "
              + ", ".join(f"{k} {v:.4g}" for k, v in extra.items()))
    return 0


_terminated_by = None  # the signal that asked hexctl to stop, once one has


def _exit_on_sigterm(signum, frame):
    # as SystemExit, so that `with` blocks unwind: `hexctl demo` stops the node processes
    # it started (they run in sessions of their own) instead of leaving them running
    global _terminated_by
    _terminated_by = signum
    raise SystemExit(128 + signum)


def _demo(args) -> int:
    """``hexctl demo``: the run's options (resumed: the stored ones, a conflict refused), the
    run; a graph that fails (a node died, the loop stood) is one line on stderr and exit 3."""
    from hex_control.ros.app.grind_job import RUN_DEFAULTS, GraphFailure, resumable_job_dir, run_demo, run_options

    given = {name: getattr(args, name) for name in RUN_DEFAULTS if getattr(args, name) is not None}
    if args.resume is not None:
        if args.jobs not in (None, 1):
            raise ValueError(f"--resume takes up one job, not --jobs {args.jobs}")
        resumable_job_dir(args.resume)  # ValueError first if there is nothing to resume
    options = run_options(given, args.resume)
    try:
        return run_demo(args.resume or args.output, options, machine_file=MACHINES[options["machine"]],
                        jobs=args.jobs or 1, machine_host=args.machine_host.split() or None,
                        machine_peers=args.machine_peers, restart_planner_after=args.restart_planner_after,
                        record=not args.no_record, resume=args.resume is not None)
    except (GraphFailure, TimeoutError) as exc:  # a graph that did not start or answer: TimeoutError
        if _terminated_by is not None:  # the nodes stopped because hexctl was told to stop
            return 128 + _terminated_by
        print(f"hexctl demo: {getattr(exc, 'one_line', exc)}", file=sys.stderr)
        return 3


def _bag_info(directory: str) -> int:
    from hex_control.recording.bag import describe

    print(describe(directory))
    return 0


def _unit_commitment(args) -> int:
    from hex_control.seeds.unit_commitment import report

    if args.verb == "table":
        summary = report.build_table(args.fleet, args.output, args.k, args.step)
        built = "read from the output folder" if summary["build_s"] is None else f"built in {summary['build_s']:.1f} s"
        print(f"{summary['fleet']}: {summary['levels']} levels {summary['levels_mw'][0]:g}..{summary['levels_mw'][1]:g}"
              f" MW, {args.k} candidates each, {built}; wrote {args.output}/table_{summary['fleet']}.png")
    elif args.verb == "day":
        summary = report.schedule_day(args.fleet, args.output, args.k, args.step, args.milp)
        print(f"{summary['fleet']}: daily cost {summary['cost']:,.1f} (running {summary['running_cost']:,.1f}, "
              f"starting {summary['starting_cost']:,.1f}), {summary['unit_cost_per_mwh']:.4f} per MWh, "
              f"scheduled in {summary['schedule_s']:.2f} s")
        if "milp" in summary:
            peer = summary["milp"]
            print(f"MILP: {peer['cost']:,.1f} (lower bound {peer['lower_bound']:,.1f}) in {peer['solve_s']:.1f} s; "
                  f"the table algorithm is {100 * peer['table_over_lower_bound']:.3f} % above the lower bound")
        print(f"wrote {args.output}/day_{summary['fleet']}.png")
    else:
        summary = report.run_online(args.fleet, args.output, args.days, args.history_days, args.std, args.a,
                                    args.seed, args.k, args.step, args.unbounded_store)
        print(f"{summary['fleet']}{' (store unbounded)' if args.unbounded_store else ''}: unit cost increase over "
              f"{args.days} days, fluctuation {100 * args.std:.2f} % std (mean ± standard error)")
        for kind, result in summary["models"].items():
            hindsight, plan = result["over_hindsight"], result["over_plan"]
            print(f"  {kind:13s} over hindsight {hindsight['mean_percent']:+.4f} ± "
                  f"{hindsight['standard_error_percent']:.4f} %, over the mean day's plan {plan['mean_percent']:+.4f}"
                  f" ± {plan['standard_error_percent']:.4f} %  (identified a = {result['identified_a']:.2f})")
        print(f"wrote {args.output}/online_{summary['fleet']}.png")
    return 0


def _chatter(args) -> int:
    from tqdm import tqdm

    from hex_control.seeds.milling.case import ChatterCase
    from hex_control.seeds.milling.study import write_study

    case = ChatterCase.from_yaml(args.case)
    with tqdm(total=len(case.programmes()) + 1, desc="chatter", unit="run") as bar:
        summary = write_study(args.output, case, progress=lambda done: (bar.set_postfix_str(done), bar.update(1)))
    print(f"tool's first bending mode {summary['first_mode_hz']:.0f} Hz, a_p = {1e3 * summary['depth_m']:.3f} mm")
    print(summary["table"])
    for speed, row in summary["lobes"].items():
        print(f"{speed} rev/min: lobe limit {1e3 * row['zero_order_limit_m']:.4f} mm (zero-order), "
              f"{1e3 * row['semi_discretization_limit_m']:.4f} mm (semi-discretization); at the chosen depth the "
              f"Floquet radius is {row['spectral_radius_at_chosen_depth']:.4f} "
              f"({'unstable' if row['spectral_radius_at_chosen_depth'] > 1 else 'stable'})")
    print(f"wrote {args.output}/chatter_spectra.png, chatter_programmes.png, chatter_lobes.png, chatter.json")
    return 0


def _platform(args) -> int:
    from pathlib import Path

    import yaml
    from tqdm import tqdm

    from hex_control.seeds.mobile_platform import study, tuning
    from hex_control.seeds.mobile_platform.case import PlatformCase

    case = PlatformCase.from_yaml(args.case)
    if args.verb == "compare":
        runs = len(study.PATHS) * len(case.tuning_plants) * len(study.CONTROLLERS)
        with tqdm(total=runs, desc="platform", unit="run") as bar:
            summary = study.write_study(args.output, case, lambda done: (bar.set_postfix_str(done), bar.update(1)))
        print(summary["table"])
        print(f"wrote {args.output}/platform_path_fig7.png, platform_path_fig10.png, platform_heading_fig7.png, "
              "platform_heading_fig10.png, platform.json")
        return 0
    tuned = {}
    for name, tune in (("energy_index", tuning.tune_energy_index), ("two_pid", tuning.tune_two_pid)):
        with tqdm(desc=f"tuning {name}", unit="run") as bar:
            tuned[name], itae = tune(case, args.iterations_per_gain, progress=lambda: bar.update(1))
        print(f"{name}: ITAE {itae:.3e} m s^2 (summed over the tuning plants)")
    Path(args.output).mkdir(parents=True, exist_ok=True)
    text = yaml.safe_dump(tuned, default_flow_style=None, sort_keys=False)
    (Path(args.output) / "tuned.yaml").write_text(text)
    print(text + f"wrote {args.output}/tuned.yaml (copy it into the case file's energy_index / two_pid)")
    return 0


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    try:
        if args.command == "demo":
            return _demo(args)
        if args.command == "demo-load-predictor":
            from hex_control.ros.app.demo_load_predictor import run_demo

            return run_demo(args.output, args.samples, args.rate, args.seed)
        if args.command == "job-stats":
            return _job_stats(args)
        if args.command == "campaign":
            return _campaign(args)
        if args.command == "workspace":
            return _workspace(args)
        if args.command == "sdp":
            return _sdp(args)
        if args.command == "shaper":
            return _shaper(args)
        if args.command == "pass":
            return _pass(args)
        if args.command == "record":
            from hex_control.ros.tools.recorder import record

            return record(args.output or time.strftime("rosbag2_%Y_%m_%d-%H_%M_%S"), args.topics, args.all,
                          args.duration)
        if args.command == "play":
            from hex_control.ros.tools.recorder import play

            return play(args.directory, args.rate, args.topics, args.wait, args.loop, args.clock, args.remap)
        if args.command == "bag":
            return _bag_info(args.directory)
        if args.command == "unit-commitment":
            return _unit_commitment(args)
        if args.command == "chatter":
            return _chatter(args)
        if args.command == "platform":
            return _platform(args)
        if args.command == "bench":
            from hex_control.bench import run_benchmarks

            return run_benchmarks(args.cases, quick=args.quick)
        return _ros_verb(args)
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


if __name__ == "__main__":
    sys.exit(main())
