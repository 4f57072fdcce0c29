"""The suite's own scheduling (conftest.py): under ``-n 4 --dist worksteal`` the first
blocks of tests of SLOW_LANES workers begin with their share of the slow ones, the others
with quick ones. The dealing runs in the workers, where xdist has set ``--dist`` to "no":
the controller hands on what it parsed (pytest_configure_node)."""

from pathlib import Path
from types import SimpleNamespace

import conftest


def _item(module: str, name: str, ros: bool):
    return SimpleNamespace(path=Path(f"/repo/test/{module}"), name=name,
                           fixturenames=["ros_env"] if ros else [])


def _config(dist: str, workers: int = 4):
    """A worker's config: the controller's --dist handed on, its own set to "no"."""
    return SimpleNamespace(workerinput={"workercount": workers, "dist": dist},
                           getoption=lambda name, default=None: "no")


def test_the_controller_hands_its_dist_mode_on_to_each_worker():
    node = SimpleNamespace(workerinput={}, config=SimpleNamespace(getoption=lambda name: "worksteal"))
    conftest.pytest_configure_node(node)
    assert node.workerinput["dist"] == "worksteal"


def _collection():
    slow = [_item("test_end_to_end.py", f"e2e_{k}", True) for k in range(6)]
    slow += [_item("test_ros_cli.py", f"cli_{k}", True) for k in range(3)]
    slow.append(_item("test_colcon_build.py", "build", True))
    short = [_item("test_sdp.py", f"unit_{k}", False) for k in range(30)]
    short.insert(0, _item("test_end_to_end.py", "helper", False))  # a unit test of a slow module
    return slow + short


def _blocks(items, workers: int = 4) -> list[list]:
    """The blocks worksteal first sends its workers (xdist's check_schedule)."""
    blocks, left = [], list(items)
    for k in range(workers):
        size = len(left) // (workers - k)
        blocks.append(left[:size])
        del left[:size]
    return blocks


def test_the_slow_lanes_start_with_their_share_of_the_slow_tests():
    items = _collection()
    conftest.pytest_collection_modifyitems(_config("worksteal"), items)
    assert sorted(i.name for i in items) == sorted(i.name for i in _collection())  # all, once
    blocks = _blocks(items)
    heads = [[i.name for i in block if conftest._is_slow(i)] for block in blocks]
    assert heads[0][0] == "e2e_0"  # the costliest first
    lanes = conftest.SLOW_LANES
    assert all(heads[:lanes]) and not any(heads[lanes:]), heads
    assert abs(len(heads[0]) - len(heads[1])) <= 3  # dealt evenly (the CLI module is one unit)
    cli_blocks = {k for k, block in enumerate(blocks) for i in block if i.name.startswith("cli")}
    assert len(cli_blocks) == 1  # the module whose fixtures serve it whole: one worker
    for block, head in zip(blocks, heads):
        assert [i.name for i in block[:len(head)]] == head  # at the block's head


def test_without_worksteal_the_slow_tests_simply_come_first():
    items = _collection()
    conftest.pytest_collection_modifyitems(_config("load"), items)
    assert [i.name for i in items[:10]] == [*(f"e2e_{k}" for k in range(6)), "cli_0", "cli_1", "cli_2", "build"]
