"""Command ownership (hex_control.safety.command_owner; issue 21 item 3, issue 37 item 3)."""

import pytest

from hex_control.safety.command_owner import CommandOwner, OwnedInput, resolve_owner_nodes


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


def test_several_configured_nodes_are_obeyed_and_a_restart_of_one_takes_over():
    """Results come from the plant, REJECTED ones from the pass planner (issue 37 item 3)."""
    graph = Graph(plant="/cell2/plant", planner="/cell2/pass_planner", rogue="/cell2/rogue")
    owner = graph.owner(("/cell2/plant", "/cell2/pass_planner"))
    assert [owner.admit(g) for g in (b"plant", b"rogue", b"planner", b"plant")] == [True, False, True, True]
    assert owner.last_refused == "/cell2/rogue"
    graph.nodes[b"plant2"] = "/cell2/plant"  # the plant restarted
    assert owner.admit(b"plant2") and not owner.admit(b"rogue")


def test_a_rogue_that_speaks_first_or_after_the_owner_stopped_never_owns_a_configured_input():
    """Issue 37: one jog command before the controller started made its sender the owner for
    the whole job; a rogue after the controller stopped locked out the restarted one."""
    graph = Graph(rogue="/jog", a="/force_controller")
    owner = graph.owner("/force_controller")
    assert not owner.admit(b"rogue") and owner.admit(b"a")
    del graph.nodes[b"a"]
    assert not owner.admit(b"rogue")
    graph.nodes[b"a2"] = "/force_controller"
    assert owner.admit(b"a2") and owner.takeovers == 1


def test_owner_names_resolve_in_the_cell_namespace():
    assert resolve_owner_nodes("plant", "/cell2") == ("/cell2/plant",)
    assert resolve_owner_nodes("plant", "/") == ("/plant",)
    assert resolve_owner_nodes("plant, pass_planner", "/c") == ("/c/plant", "/c/pass_planner")
    assert resolve_owner_nodes(("/abs/x", "y"), "/c") == ("/abs/x", "/c/y")
    assert resolve_owner_nodes("", "/c") == ()
    assert resolve_owner_nodes(None, "/c") is None
    with pytest.raises(ValueError, match="not a node name"):
        resolve_owner_nodes("a//b", "/c")


def test_a_message_of_an_unnamed_publisher_waits_for_its_name_and_keeps_its_order():
    graph = Graph(late=None)
    gate = OwnedInput(graph.owner("/plant"), hold_s=5.0)
    assert gate.offer(b"late", "m1", 0.0) == ([], 0)
    assert gate.offer(b"late", "m2", 0.1) == ([], 0) and gate.waiting == 2
    assert gate.retry(0.2) == ([], 0)  # still unnamed
    graph.nodes[b"late"] = "/plant"
    assert gate.retry(0.3) == ([(b"late", "m1"), (b"late", "m2")], 0) and gate.waiting == 0
    assert gate.offer(b"late", "m3", 0.4) == ([(b"late", "m3")], 0)


def test_an_unnamed_or_foreign_publisher_is_refused_in_the_end_and_a_flood_is_bounded():
    graph = Graph(never=None, rogue="/rogue")
    gate = OwnedInput(graph.owner("/plant"), hold_s=1.0, depth=3, publishers=2)
    assert gate.offer(b"rogue", "x", 0.0) == ([], 1)
    for i in range(5):  # only the latest 3 wait
        _, refused = gate.offer(b"never", i, 0.0)
    assert gate.waiting == 3
    assert gate.retry(0.5) == ([], 0) and gate.retry(1.0) == ([], 3) and gate.waiting == 0
    for gid in (b"u1", b"u2", b"u3"):  # more unnamed publishers than kept: the oldest wait goes
        gate.offer(gid, gid, 2.0)
    assert gate.waiting == 2
    with pytest.raises(ValueError):
        OwnedInput(graph.owner("/plant"), hold_s=0)
