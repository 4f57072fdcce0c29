"""Benchmarks: each case times the library against a baseline run in the same process
and prints the figure and the ratio. ``hexctl bench [case ...] [--quick]``.

Add a case by decorating a function ``case(quick: bool) -> list[str]`` (printed lines)
with :func:`benchmark` in a module imported below.
"""

from __future__ import annotations

import importlib
import time
from typing import Callable

CASES: dict[str, Callable[[bool], list[str]]] = {}


def benchmark(name: str):
    def register(function):
        CASES[name] = function
        return function
    return register


def best_time(function, repeat: int = 5) -> float:
    """Best wall time of ``repeat`` calls (s): the least disturbed by a noisy machine."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def run_benchmarks(names, quick: bool = False) -> int:
    for module in ("estimation", "graph", "graph_starts", "grinding", "kinematics", "loop", "milling",
                   "mobile_platform", "plant", "pru3_tracking", "sdp", "shaping", "topic_tools", "unit_commitment"):
        importlib.import_module(f"hex_control.bench.{module}")  # registers its cases

    unknown = [n for n in names if n not in CASES]
    if unknown:
        print(f"unknown benchmark(s) {unknown}; available: {sorted(CASES)}")
        return 2
    for name in names or sorted(CASES):
        print(f"== {name}")
        for line in CASES[name](quick):
            print(f"   {line}")
    return 0
