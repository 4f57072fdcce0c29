"""hexctl view: the running cell in Foxglove, over the Foxglove WebSocket protocol
(hex_control/ros/app/foxglove_server.py). rclpy and foxglove-sdk load only inside the verb."""

from __future__ import annotations


def add_parsers(commands) -> None:
    view = commands.add_parser(
        "view", help="serve the running cell to Foxglove (3-D scene from TF and the URDF, bead, forces, pass table)",
        epilog="open it in Foxglove: Open connection -> Foxglove WebSocket -> ws://HOST:PORT; the layout "
               "config/foxglove/hex_control.json arranges the panels (also for a demo's recording)")
    view.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1; 0.0.0.0: all)")
    view.add_argument("--port", type=int, default=8765, help="TCP port (default 8765; 0: a free one)")
    view.add_argument("--namespace", default="", help="the cell's namespace, e.g. /cell2 (default: the root)")
    view.add_argument("--duration", type=float, default=0.0, help="stop after this many wall seconds (0: at Ctrl-C)")
    view.set_defaults(func=_view)


def _view(args) -> int:
    from hex_control.grinding.run_files import validated_namespace

    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port must be 0..65535, got {args.port}")
    if not 0 <= args.duration < float("inf"):  # NaN too: it would serve for ever
        raise ValueError(f"--duration must be a finite number of seconds >= 0, got {args.duration}")
    if not args.host.strip():
        raise ValueError("--host must name an address, e.g. 127.0.0.1")
    namespace = validated_namespace(args.namespace)
    from hex_control.ros.app.foxglove_server import serve

    return serve(args.host, args.port, namespace, duration_s=args.duration)
