"""Named faults behind every node's /diagnostics level (hex_control.ros.infra.diagnostics.Health)."""

from hex_control.ros.infra.diagnostics import ERROR, OK, WARN, Health


class FakeClock:
    def __init__(self):
        self.now_s = 0.0

    def __call__(self):
        return self.now_s


def test_the_level_is_the_worst_active_fault_and_each_clears_on_its_own():
    health = Health(FakeClock())
    health.state = "tracking"
    assert health.summary() == (OK, "tracking")
    health.fault("watchdog", "watchdog: stale setpoint")
    health.fault("clock", "no /clock publisher", ERROR)
    assert health.summary() == (ERROR, "watchdog: stale setpoint; no /clock publisher")
    health.clear("clock")
    assert health.summary() == (WARN, "watchdog: stale setpoint")
    health.clear("watchdog")
    health.clear("never raised")
    assert health.summary() == (OK, "tracking")


def test_an_event_warns_for_its_hold_after_the_last_occurrence():
    clock = FakeClock()
    health = Health(clock)
    health.fault("rejected", "rejected non-finite measurement nan", hold_s=10.0)
    clock.now_s = 9.0
    health.fault("rejected", "rejected measurement 1e9 outside (0, 1000)", hold_s=10.0)  # renewed
    clock.now_s = 18.9
    assert health.summary() == (WARN, "rejected measurement 1e9 outside (0, 1000)")
    clock.now_s = 19.0
    assert health.summary() == (OK, "ok") and not health.active("rejected")
