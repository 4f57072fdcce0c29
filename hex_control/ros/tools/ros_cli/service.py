"""``hexctl service list|call``. A call is resent while unanswered (see
:mod:`hex_control.ros.tools.ros_cli.param`) unless ``--no-resend``: give that for a service that must
not run twice."""

from __future__ import annotations

import yaml

from hex_control.ros.infra.messages import to_primitive
from hex_control.ros.tools.ros_cli.common import (
    absolute,
    cli_node,
    hidden,
    interface_message,
    settle_graph,
    spin_until,
)
from hex_control.ros.tools.ros_cli.param import answer


def service_list(show_types: bool, wait_s: float, include_hidden: bool = False) -> int:
    """Every service, once this verb's own discovery has settled (hexctl asks the daemon
    first); an action's ``_action/...`` ones with ``include_hidden``."""
    with cli_node("hexctl_service_list") as node:
        settle_graph(node, wait_s)
        services = node.get_service_names_and_types()
    for name, types in sorted(services):
        if hidden(name) and not include_hidden:
            continue
        print(f"{name} [{', '.join(types)}]" if show_types else name)
    return 0


def service_call(service: str, type_name: str, values: str, timeout_s: float, resend: bool) -> int:
    cls, request = interface_message(type_name, "srv", "Request", values)
    service = absolute(service)
    with cli_node("hexctl_service_call") as node:
        client = node.create_client(cls, service)
        spin_until(node, client.service_is_ready, timeout_s, f"service {service}")
        print(f"requester: making request: {to_primitive(request)}", flush=True)
        if resend:
            response = answer(node, lambda: client.call_async(request), timeout_s, f"response from {service}")
        else:
            future = client.call_async(request)
            spin_until(node, future.done, timeout_s, f"response from {service}")
            response = future.result()
        print("response:\n" + yaml.safe_dump(to_primitive(response), sort_keys=False, default_flow_style=None)
              .rstrip())
    return 0
