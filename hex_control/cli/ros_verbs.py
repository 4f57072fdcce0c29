"""hexctl topic, node, param, service, action, interface: ros2cli's verbs
(hex_control/ros/tools/ros_cli/, loaded only inside a verb)."""

from __future__ import annotations

#: list and info verbs wait until discovery has settled (hex_control.ros.tools.ros_cli.common.settle_graph),
#: at most this long (s)
GRAPH_WAIT_S = 10.0
GRAPH_WAIT_HELP = "wait at most this long (s) for discovery to settle (it ends sooner when the graph stands still)"

ROS_COMMANDS = ("topic", "node", "param", "service", "action", "interface", "daemon")


def add_parsers(commands) -> None:
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
    for command in ROS_COMMANDS:
        commands.choices[command].set_defaults(func=_ros_verb)


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
    daemon = commands.add_parser("daemon", help="the graph daemon that list verbs and echo use (ros2 daemon)")
    daemon.add_argument("verb", choices=["start", "stop", "status"])
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


def _through_daemon(args) -> int | None:
    """The verb answered by the hexctl daemon (hex_control/ros/tools/ros_cli/daemon.py), whose
    client imports neither rclpy nor numpy; None if it does not answer that verb or no daemon
    runs (the verb then discovers the graph itself)."""
    from hex_control.ros.tools.ros_cli import daemon

    if daemon.disabled():
        return None
    if args.verb == "list" and args.command in ("topic", "node", "service", "action") \
            and not (args.command == "topic" and args.show_types):
        return daemon.list_verb(args.command, args.wait, show_types=getattr(args, "show_types", False),
                                include_hidden=getattr(args, "include_hidden", False))
    if args.command == "topic" and args.verb == "echo":
        return daemon.echo_verb(args.topic, 1 if args.once else args.count, args.field, args.timeout,
                                durability=args.qos_durability, reliability=args.qos_reliability,
                                depth=args.qos_depth)
    return None


def _ros_verb(args) -> int:
    if args.command != "daemon" and (code := _through_daemon(args)) is not None:
        return code
    if args.command == "topic":
        from hex_control.ros.tools.ros_cli import topic

        if args.verb == "list":
            return topic.topic_list(args.show_types, args.wait, args.include_hidden)
        if args.verb == "info":
            return topic.topic_info(args.topic, args.verbose, args.wait)
        if args.verb == "echo":
            return topic.topic_echo(args.topic, args.once, args.count, args.field, args.timeout,
                                    durability=args.qos_durability, reliability=args.qos_reliability,
                                    depth=args.qos_depth)
        if args.verb == "hz":
            return topic.topic_hz(args.topic, args.window, args.duration, args.timeout)
        return topic.topic_pub(args.topic, args.type, args.values, args.rate, 1 if args.once else args.times,
                               wait_s=args.wait, durability=args.qos_durability, reliability=args.qos_reliability,
                               depth=args.qos_depth)
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
    if args.command == "daemon":
        from hex_control.ros.tools.ros_cli.daemon import daemon_verb

        return daemon_verb(args.verb)
    if args.command == "interface":
        from hex_control.ros.tools.ros_cli.interface import interface_show

        return interface_show(args.type)
    from hex_control.ros.tools.ros_cli import action

    if args.verb == "list":
        return action.action_list(args.show_types, args.wait)
    return action.send_goal(args.action, args.type, args.values, args.feedback, args.timeout)
