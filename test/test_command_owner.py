"""The plant's command ownership rule (hex_control.plant.command_owner; issue 21, item 3)."""

import pytest

from hex_control.plant.command_owner import CommandOwner


class Graph:
    """Publishers on one topic: GID -> fully qualified node name (None: not yet discovered)."""

    def __init__(self, **publishers):
        self.nodes = {gid.encode(): name for gid, name in publishers.items()}

    def owner(self, owner_node=""):
        return CommandOwner(lambda gid: self.nodes.get(gid), lambda gid: gid in self.nodes, owner_node)


def test_the_first_publisher_owns_the_input_and_others_are_refused():
    graph = Graph(a="/force_controller", rogue="/rogue")
    owner = graph.owner()
    assert [owner.admit(g) for g in (b"a", b"rogue", b"a", b"rogue")] == [True, False, True, False]
    assert owner.owner_node == "/force_controller" and owner.takeovers == 0


def test_a_restarted_owner_takes_over_under_its_name_while_the_old_publisher_lingers():
    graph = Graph(a="/force_controller", rogue="/rogue")
    owner = graph.owner()
    assert owner.admit(b"a")
    graph.nodes[b"a2"] = "/force_controller"  # killed: b"a" stays in the graph until its lease ends
    assert owner.admit(b"a2") and not owner.admit(b"rogue")
    assert owner.takeovers == 1


def test_anyone_may_take_over_once_the_owner_has_left_the_graph():
    graph = Graph(a="/force_controller", b="/jog")
    owner = graph.owner()
    assert owner.admit(b"a") and not owner.admit(b"b")
    del graph.nodes[b"a"]
    assert owner.admit(b"b") and owner.owner_node == "/jog"


def test_a_configured_owner_is_the_only_node_obeyed_even_when_first_or_alone():
    graph = Graph(rogue="/rogue", unknown=None, a="/force_controller")
    owner = graph.owner("/force_controller")
    assert not owner.admit(b"rogue") and not owner.admit(b"unknown")
    assert owner.admit(b"a")
    del graph.nodes[b"a"]
    assert not owner.admit(b"rogue")  # gone owner: still nobody else


def test_an_undiscovered_publisher_is_not_obeyed_over_a_present_owner():
    graph = Graph(a="/force_controller", new=None)
    owner = graph.owner()
    assert owner.admit(b"a") and not owner.admit(b"new")
    graph.nodes[b"new"] = "/force_controller"  # discovery catches up: the owner's restart
    assert owner.admit(b"new")


def test_an_owner_name_must_be_fully_qualified():
    with pytest.raises(ValueError, match="fully qualified"):
        Graph().owner("force_controller")
