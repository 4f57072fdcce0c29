"""``hexctl node list|info``: the nodes of the graph and what each one offers. Both wait
until discovery has settled (:func:`~hex_control.ros.tools.ros_cli.common.settle_graph`);
info hides the hidden topics and services (an action's ``_action/...`` internals) unless
``include_hidden``, as ``ros2 node info`` does."""

from __future__ import annotations

from rclpy.action import get_action_client_names_and_types_by_node, get_action_server_names_and_types_by_node

from hex_control.ros.tools.ros_cli.common import VerbError, cli_node, hidden, settle_graph


def _nodes(node) -> list[str]:
    names = [f"{ns.rstrip('/')}/{name}" for name, ns in node.get_node_names_and_namespaces()]
    return sorted(n for n in set(names) if not n.rsplit("/", 1)[-1].startswith(("hexctl_", "_")))


def node_list(wait_s: float) -> int:
    """The nodes once this verb's own discovery has settled (hexctl asks the daemon first)."""
    with cli_node("hexctl_node_list") as node:
        settle_graph(node, wait_s)
        for name in _nodes(node):
            print(name)
    return 0


def node_info(name: str, wait_s: float, include_hidden: bool = False) -> int:
    if not name.startswith("/"):
        name = "/" + name
    with cli_node("hexctl_node_info") as node:
        settle_graph(node, wait_s)
        if name not in _nodes(node):
            raise VerbError(f"unknown node {name} (hexctl node list)")
        namespace, _, base = name.rpartition("/")
        namespace = namespace or "/"
        sections = (("Subscribers", node.get_subscriber_names_and_types_by_node(base, namespace)),
                    ("Publishers", node.get_publisher_names_and_types_by_node(base, namespace)),
                    ("Service Servers", node.get_service_names_and_types_by_node(base, namespace)),
                    ("Service Clients", node.get_client_names_and_types_by_node(base, namespace)),
                    ("Action Servers", get_action_server_names_and_types_by_node(node, base, namespace)),
                    ("Action Clients", get_action_client_names_and_types_by_node(node, base, namespace)))
        print(name)
        for title, entries in sections:
            print(f"  {title}:")
            for topic, types in sorted(entries):
                if include_hidden or not hidden(topic):
                    print(f"    {topic}: {', '.join(types)}")
    return 0
