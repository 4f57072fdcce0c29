"""Playing a recording at its recorded pace, without ROS: :func:`paced` hands out the
messages when they are due, :func:`parse_remaps` reads ``from:=to`` topic remaps.

Each message is due at ``start + (t - t_first) / rate`` on a monotonic clock, ``start``
being when the first one was handed out: the schedule is the recorded timeline itself.
Sleeping each gap instead adds every publish's and every wake-up's own time to the
total (a 45.5 s recording took 49.7 s); here a late message is sent at once and the ones
after it are due at their own times, so lateness does not accumulate.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator


def paced(messages: Iterable[tuple], rate: float = 1.0, now: Callable[[], float] = time.monotonic,
          sleep: Callable[[float], object] = time.sleep, tick: Callable[[int], None] | None = None,
          *, tick_period_s: float = 0.025, stopped: Callable[[], bool] = lambda: False) -> Iterator[tuple]:
    """Yield each of ``messages`` (tuples whose last item is the recorded time, ns, in time
    order) when due at ``rate`` times the recorded pace on the clock ``now`` (s). While
    waiting, ``tick(recorded time now, ns)`` is called every ``tick_period_s`` of wall time
    (a /clock publisher). Ends early when ``stopped()``."""
    if not rate > 0:
        raise ValueError(f"need a rate > 0, got {rate}")
    start = first = None
    next_tick = None
    for message in messages:
        time_ns = message[-1]
        if start is None:
            start, first = now(), time_ns
            next_tick = start
        due = start + (time_ns - first) / 1e9 / rate
        while True:
            if stopped():
                return
            current = now()
            if tick is not None and current >= next_tick:
                tick(first + int(round((current - start) * rate * 1e9)))
                next_tick += tick_period_s
                if next_tick <= current:  # late: the next one a period from now, not at once
                    next_tick = current + tick_period_s
            if current >= due:
                break
            sleep(min(due, next_tick) - current if tick is not None else due - current)
        yield message


def parse_remaps(remaps: Iterable[str] | None) -> dict[str, str]:
    """``["/a:=/b", ...]`` as ``{"/a": "/b"}``; names made absolute; ValueError on a bad one."""
    mapping = {}
    for remap in remaps or ():
        source, separator, target = remap.partition(":=")
        if not separator or not source.strip() or not target.strip():
            raise ValueError(f"a remap is FROM:=TO, e.g. /plant/wrench:=/old/wrench, got {remap!r}")
        source, target = ("/" + n.strip().lstrip("/") for n in (source, target))
        mapping[source] = target
    return mapping
