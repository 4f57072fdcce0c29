"""The loaded machine of the determinism test (cpu_load.py): burners fill what the rest of
the machine leaves, until the runnable tasks outnumber the cores."""

import os

import pytest
from cpu_load import LoadedMachine, burners_wanted

from ros_harness import wait_until


@pytest.mark.parametrize(("others", "cores", "wanted"), [
    (0.0, 2, 2),  # an idle machine: a burner per core, as two plain burners
    (1.0, 2, 2),  # beside a one-core job
    (1.5, 2, 2),
    (2.0, 2, 1),  # two cores' worth already: one more makes some task wait
    (2.6, 2, 1),
    (3.0, 2, 0),  # already one runnable task more than the cores
    (9.0, 2, 0),
    (0.0, 4, 4),
])
def test_burners_fill_the_machine_to_one_runnable_task_more_than_its_cores(others, cores, wanted):
    assert burners_wanted(others, cores) == wanted


def test_held_the_machine_runs_a_task_on_every_core():
    """Alone the burners fill the cores; a job beside them is what waits (test_determinism)."""
    with LoadedMachine(tick_s=0.05) as load:
        wait_until(lambda: load.reads >= 50, 60.0, what="five ticks of the load's reads")
        burners = [burner.pid for burner in load.burners]
    assert len(burners) == load.cores == len(os.sched_getaffinity(0))
    assert load.runnable_mean >= load.cores
    assert all(not os.path.exists(f"/proc/{pid}") for pid in burners)  # killed and reaped
