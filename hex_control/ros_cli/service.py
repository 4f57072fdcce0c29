"""``hexctl service list|call``. A call is resent while unanswered (see
:mod:`hex_control.ros_cli.param`) unless ``--no-resend``: give that for a service that must
not run twice."""

from __future__ import annotations

import importlib
import re

import yaml

from hex_control.nodes.messages import fill_message, to_primitive
from hex_control.ros_cli.common import VerbError, absolute, cli_node, spin_for, spin_until, yaml_mapping
from hex_control.ros_cli.param import answer


def service_class(type_name: str):
    """The class of ``pkg/srv/Name``."""
    parts = re.split(r"[/.]", type_name.strip())
    if len(parts) == 2:
        parts = [parts[0], "srv", parts[1]]
    try:
        cls = getattr(importlib.import_module(f"{parts[0]}.{parts[1]}"), parts[2])
    except (ImportError, AttributeError, IndexError):
        raise VerbError(f"unknown service type {type_name!r} (want pkg/srv/Name)") from None
    if not hasattr(cls, "Request"):
        raise VerbError(f"{type_name!r} is not a service type")
    return cls


def service_list(show_types: bool, wait_s: float) -> int:
    with cli_node("hexctl_service_list") as node:
        spin_for(node, wait_s)
        for name, types in sorted(node.get_service_names_and_types()):
            print(f"{name} [{', '.join(types)}]" if show_types else name)
    return 0


def service_call(service: str, type_name: str, values: str, timeout_s: float, resend: bool) -> int:
    cls = service_class(type_name)
    try:
        request = fill_message(cls.Request(), yaml_mapping(values, "the request"))
    except (TypeError, ValueError, AssertionError) as exc:
        raise VerbError(f"cannot build the request of {type_name} from {values!r}: {exc}") from None
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
