"""Entry-point plumbing shared by every node's ``main``.

SIGINT and SIGTERM set an event that the spin loop checks between waits of at most 0.1 s.
rclpy's own handlers are not installed: they shut the context down from a thread of their
own, and a SIGTERM that arrived as a node started could be lost that way (the node then spun
on, seen once in about 100 starts).

Nodes spin on rclpy's ``EventsExecutor`` (``HEX_EXECUTOR=single`` for the
SingleThreadedExecutor): it measured 2,150-2,540 cross-process round trips/s here against
580-830 for the SingleThreadedExecutor, at less than half the CPU per round trip
(``hexctl bench graph`` compares the two on the whole graph). The job's observer and
recorder and ``hexctl record`` take the same executor (:func:`make_executor`)."""

from __future__ import annotations

import faulthandler
import gc
import io
import os
import signal
import sys
import threading
from concurrent.futures import Future

import rclpy
from rclpy._rclpy_pybind11 import InvalidHandle
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

WAIT_S = 0.1  # longest wait between two looks at the stop event


def make_executor(context=None):
    """The executor a node spins on: events-based unless HEX_EXECUTOR=single.

    rclpy's EventsExecutor enables faulthandler on ``sys.stderr``, which needs a file
    descriptor: where stderr is captured without one (pytest's capsys, a notebook; the job's
    observer runs in such processes) it is given the process's own stderr meanwhile, and
    without that the SingleThreadedExecutor is used."""
    if os.environ.get("HEX_EXECUTOR", "events") == "single":
        return SingleThreadedExecutor(context=context)
    from rclpy.experimental import EventsExecutor

    try:
        sys.stderr.fileno()
    except (AttributeError, ValueError, io.UnsupportedOperation):
        if sys.__stderr__ is None:
            return SingleThreadedExecutor(context=context)
        captured, sys.stderr = sys.stderr, sys.__stderr__
        try:
            return EventsExecutor(context=context)
        finally:
            sys.stderr = captured
    return EventsExecutor(context=context)


def wall_timer(node, period_s: float, callback):
    """A timer on the steady wall clock, whatever use_sim_time says: transport waits,
    watchdogs and diagnostics must run while the sim clock stands still (DESIGN.md 4.1)."""
    return node.create_timer(period_s, callback, clock=Clock(clock_type=ClockType.STEADY_TIME))


def stop_on_signals() -> threading.Event:
    """An event that SIGINT and SIGTERM set (in the main thread, between bytecodes)."""
    stop = threading.Event()
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda _number, _frame: stop.set())
    return stop


def init(args=None) -> threading.Event:
    """Install the stop handlers, then init rclpy without its own; the stop event. SIGUSR1
    writes every thread's traceback to stderr (a hung node says where, whichever thread the
    signal lands on: a fatal-signal dump taken on a DDS thread showed no Python frames)."""
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    stop = stop_on_signals()
    rclpy.init(args=sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO)
    return stop


_background: set[threading.Thread] = set()  # threads started by in_background, while they run


def in_background(function, *args, then: tuple | None = None) -> Future:
    """``function(*args)`` on a daemon thread; its Future, which the node polls from its
    executor. ``then`` = (node, callback): once the future is done, ``callback`` runs on the
    node's executor at once rather than at the next poll (a pass waits for each hand-over
    while the plant's clock stands). Daemon, because the interpreter joins a
    ThreadPoolExecutor's threads at exit: a node stopped amid a long computation (a policy
    solve, a pass plan, a shaper design) would not exit until it ended."""
    future = Future()

    def run():
        try:
            if future.set_running_or_notify_cancel():
                future.set_result(function(*args))
        except BaseException as exc:  # handed to the poller, which decides
            future.set_exception(exc)
        finally:
            try:
                if then is not None:
                    wake(*then)
            finally:  # counted until here: at exit, a thread inside the executor's queue is still running
                _background.discard(threading.current_thread())

    thread = threading.Thread(target=run, name=getattr(function, "__name__", "background"), daemon=True)
    _background.add(thread)
    thread.start()
    return future


#: wall s: how often a node polls for its timeouts; background work it waits on wakes it when
#: done (``in_background``'s ``then``), so this is a backstop, not a latency
POLL_S = 0.1


def wake(node, callback) -> None:
    """Run ``callback`` on ``node``'s executor soon; safe from any thread (the events
    executor has no guard conditions, but its task queue, like rclpy's executors', takes
    work from any thread). Before the node spins, nothing: its poll timer still runs."""
    executor = node.executor
    if executor is not None:
        try:
            executor.create_task(callback)
        except InvalidHandle:  # shut down meanwhile (its guard condition destroyed): nobody to wake
            pass


def _exit_past_background_work(code: int) -> None:
    """Exit now if a background computation still runs: at interpreter shutdown a daemon
    thread inside native code (scipy's C++ FFT) is unwound and aborts the process (seen as
    'terminate called without an active exception', exit -6). ROS is shut down by then."""
    if running := sum(thread.is_alive() for thread in _background):
        print(f"exiting amid {running} background computation(s): abandoned", file=sys.stderr)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def spin_until_stopped(executor, stop: threading.Event) -> None:
    """Run callbacks in short waits until ``stop`` is set."""
    while not stop.is_set() and rclpy.ok():
        executor.spin_once(timeout_sec=WAIT_S)


def ready_line(node) -> str:
    """The one line a node logs once it is up: its full name and the parameters its class
    names in ``READY_PARAMETERS`` (files by their name), and sim time if it runs on it."""
    shown = []
    for name in getattr(node, "READY_PARAMETERS", ()):
        value = node.get_parameter(name).value
        shown.append(f"{name}={os.path.basename(value) if isinstance(value, str) and '/' in value else value}")
    if node.get_parameter("use_sim_time").value:
        shown.append("sim time")
    return f"ready: {node.get_fully_qualified_name()}" + (f" ({', '.join(shown)})" if shown else "")


def create_node(node_class):
    """``node_class()``; if it refuses its parameters (a value out of range, a bad choice, a
    missing file), the reason on one line, not a traceback, and the process ends with exit
    code 2 at once: the half-made node is never torn down (freeing it with the exception
    crashed rclpy once, a segmentation fault instead of the line's exit code 2)."""
    try:
        return node_class()
    except (ParameterException, ValueError, OSError) as exc:
        print(f"{node_class.__name__}: {exc}", file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(2)


def run_node(node_class, args=None) -> int:
    """Init rclpy, spin ``node_class()`` until Ctrl-C / SIGTERM, shut down cleanly. A node
    that refuses its parameters exits with 2 (:func:`create_node`). A node with
    ``companions()`` (nodes serving its long requests) has each spun on an executor and a
    thread of its own, and its class's ``SWITCH_INTERVAL_S`` (if set) is the process's GIL
    switch interval."""
    stop = init(args)
    nodes, executors, workers = [], [], []
    try:
        node = create_node(node_class)
        nodes = [node, *getattr(node, "companions", list)()]
        if interval_s := getattr(node_class, "SWITCH_INTERVAL_S", None):
            sys.setswitchinterval(interval_s)
        node.get_logger().info(ready_line(node))
        # what start-up built (modules, tables: ~150 000 objects) lives as long as the node: out of
        # the collector's sight, a full collection no longer walks it (0.2 s a time, amid a lock-step period)
        gc.freeze()
        executors = [make_executor() for _ in nodes]
        for executor, each in zip(executors, nodes):
            executor.add_node(each)
        workers = [threading.Thread(target=spin_until_stopped, args=(executor, stop), daemon=True)
                   for executor in executors[1:]]
        for worker in workers:
            worker.start()
        spin_until_stopped(executors[0], stop)
    finally:
        # the workers leave their wait sets before any executor or node is torn down:
        # shutting down an executor another thread is waiting in can crash the process
        stop.set()
        for worker in workers:
            worker.join(timeout=10.0)
        for executor in executors:
            executor.shutdown(timeout_sec=1.0)
        for each in nodes:
            each.destroy_node()
        rclpy.try_shutdown()
    _exit_past_background_work(0)
    return 0
