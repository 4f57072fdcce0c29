"""Reading message info on either executor, and counting the messages lost on the way
(hex_control.ros.infra.message_info; issue 21 item 8: drops under a flood were not counted)."""

from hex_control.ros.infra.message_info import LostMessages, _WithMessageInfo


def test_both_executor_calling_conventions_reach_the_callback():
    got = []
    callback = _WithMessageInfo(lambda msg, info: got.append((msg, info)))
    callback("m1", {"k": 1})  # SingleThreadedExecutor
    callback(("m2", {"k": 2}))  # EventsExecutor of these wheels
    assert got == [("m1", {"k": 1}), ("m2", {"k": 2})]


def test_gaps_in_each_publishers_sequence_are_counted_as_lost():
    lost = LostMessages()
    assert lost.lost(b"a", 46) == 0  # the first heard: what went before was never ours
    assert [lost.lost(b"a", s) for s in (47, 50, 51)] == [0, 2, 0]
    assert lost.lost(b"b", 7) == 0 and lost.lost(b"b", 9) == 1  # publishers apart
    assert lost.lost(b"a", 40) == 0  # a restarted publisher counts afresh
    assert lost.lost(b"a", None) == 0  # a middleware without sequence numbers


def test_only_the_latest_publishers_are_remembered():
    lost = LostMessages()
    for gid in range(100):
        lost.lost(bytes([gid]), 1)
    assert lost.lost(bytes([99]), 3) == 1 and lost.lost(bytes([0]), 3) == 0  # 0 was forgotten


def test_a_clock_published_besides_the_plant_is_named(ros):
    """The pass planner times a pass from its node's clock only while /clock has no publisher
    besides the plant (a forged clock 400 s ahead made the plant idle to it and changed the
    part); ``foreign_publishers`` names the others, as the graph tells them."""
    from rosgraph_msgs.msg import Clock

    from hex_control.ros.infra.message_info import foreign_publishers
    from ros_harness import wait_until

    planner, plant, rogue = ros.node("pass_planner"), ros.node("plant"), ros.node("rogue")
    plant.create_publisher(Clock, "/clock", 10)
    wait_until(lambda: len(planner.get_publishers_info_by_topic("/clock")) == 1, 30.0, what="the plant's /clock")
    assert foreign_publishers(planner, "/clock", "plant") == []
    rogue.create_publisher(Clock, "/clock", 10)
    wait_until(lambda: len(planner.get_publishers_info_by_topic("/clock")) == 2, 30.0, what="the rogue's /clock")
    assert foreign_publishers(planner, "/clock", "plant") == ["/rogue"]
    assert foreign_publishers(planner, "/clock", "/rogue") == ["/plant"]
