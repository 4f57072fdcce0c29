"""The force laws the force controller runs: ``command(desired_n, measured_n)`` -> table
position command (mm).

- :class:`PIForceLaw`: the Tustin PI of eq. 7.6 with an optional roll-off filter on its
  output (seed 002 section 8.3 item 2), so the table is not driven at the disk-runout
  frequencies the sensor passes through.
- :class:`EnergyForceLaw`: the energy-index optimal control of seed 004 (eq. 9-10) on the
  table's position loop (eq. 7.3), with the table position and speed recovered from the
  measured force through the compliance K_x.

Each is a :class:`ForceLaw`; ``FORCE_LAWS`` names them, and :func:`make_force_law` builds
one from the force controller's parameters (a new law: a class and a builder here).
"""

from __future__ import annotations

import math
from typing import Callable, Mapping, Protocol

from hex_control.control.energy_optimal import EnergyIndexController
from hex_control.control.filters import low_pass, notch
from hex_control.control.pi import TustinPI

ROLL_OFFS = ("none", "lowpass", "notch")


class ForceLaw(Protocol):
    """A table position command (mm) from the desired and measured normal force (N)."""

    def reset(self, output: float) -> None:
        """Bumpless start from a held command (mm)."""

    def hold(self, output: float) -> None:
        """The loop is not running (watchdog): follow the held command (mm)."""

    def command(self, desired_n: float, measured_n: float, feed_forward_mm: float = 0.0) -> float: ...


def roll_off_filter(kind: str, frequency_hz: float, period_s: float, quality: float = 0.5):
    """None, a 2-pole low-pass at ``frequency_hz``, or a notch there (width frequency/quality)."""
    if kind == "none":
        return None
    if kind == "lowpass":
        return low_pass(frequency_hz, period_s)
    if kind == "notch":
        return notch(frequency_hz, period_s, quality)
    raise ValueError(f"roll_off must be one of {', '.join(ROLL_OFFS)}, got {kind!r}")


class PIForceLaw:
    """u_k = F(z) PI(e_k), e_k = desired - measured force. The PI's limits apply before the
    filter, which may overshoot them briefly: whoever sends the command clamps it again."""

    def __init__(self, pi: TustinPI, roll_off=None):
        self.pi, self.roll_off = pi, roll_off

    def reset(self, output: float) -> None:
        """Bumpless start from a held command."""
        self.pi.reset(output)
        if self.roll_off is not None:
            self.roll_off.reset(output)

    def hold(self, output: float) -> None:
        """The loop is not running (watchdog): keep the filter at the held command."""
        if self.roll_off is not None:
            self.roll_off.reset(output)

    def command(self, desired_n: float, measured_n: float, feed_forward_mm: float = 0.0) -> float:
        command = self.pi.step(desired_n - measured_n, feed_forward_mm)
        return command if self.roll_off is None else self.roll_off.step(command)


class EnergyForceLaw:
    """Seed 004's control on the table: M = 1, L = b1 + b2, K = b1 b2, B_u = -b1 b2 (so the
    position loop x'' + L x' + K x = b1 b2 u is eq. 1 in the seed's sign convention).

    The desired displacement (eq. 4) is the table position that gives the desired force,
    q_bar = contact + F_d / K_x; the table holds it with u = q_bar (unit DC gain), so the law
    commands u = q_bar + u_9, u_9 the eq. 9 correction clipped to +-``correction_limit_mm``
    (eq. 10). The state is estimated from the measured force: q = contact + F / K_x (the
    table cannot be seen out of contact, where the last estimate is held), q' by backward
    differences. There is no integral action: stiction leaves a steady error up to its play.
    """

    def __init__(self, period_s: float, stiffness_n_per_mm: float, contact_mm: float, pole1_hz: float = 9.0,
                 *, pole2_hz: float = 40.0, q1: float = 1.0, q2: float = 1.0, r: float = 1e-3,
                 correction_limit_mm: float = 0.5, output_min: float = -math.inf, output_max: float = math.inf):
        if not (stiffness_n_per_mm > 0 and period_s > 0):
            raise ValueError("stiffness and period must be > 0")
        b1, b2 = 2 * math.pi * pole1_hz, 2 * math.pi * pole2_hz
        self.law = EnergyIndexController(1.0, b1 + b2, b1 * b2, -b1 * b2, q1=q1, q2=q2, r=r, horizon_s=period_s,
                                         limits=[correction_limit_mm])
        self.period_s, self.stiffness, self.contact_mm = period_s, stiffness_n_per_mm, contact_mm
        self.output_min, self.output_max = output_min, output_max
        self.reset(contact_mm)

    def reset(self, output: float) -> None:
        self._position = self._previous = output

    def hold(self, output: float) -> None:
        self.reset(output)

    def command(self, desired_n: float, measured_n: float, feed_forward_mm: float = 0.0) -> float:
        if not (math.isfinite(desired_n) and math.isfinite(measured_n) and math.isfinite(feed_forward_mm)):
            raise ValueError("desired and measured force and feed-forward must be finite")
        self._previous = self._position
        if measured_n > 0:
            self._position = self.contact_mm + measured_n / self.stiffness
        speed = (self._position - self._previous) / self.period_s
        target = self.contact_mm + desired_n / self.stiffness
        correction = float(self.law.command(self._position, speed, target)[0])
        return min(max(target + correction + feed_forward_mm, self.output_min), self.output_max)


def _pi_law(p: Mapping, period_s: float, limits_mm: tuple[float, float]) -> PIForceLaw:
    return PIForceLaw(TustinPI(p["kp_mm_per_n"], p["ki_mm_per_n_s"], period_s, *limits_mm),
                      roll_off_filter(p["roll_off"], p["roll_off_hz"], period_s, p["roll_off_quality"]))


def _energy_law(p: Mapping, period_s: float, limits_mm: tuple[float, float]) -> EnergyForceLaw:
    return EnergyForceLaw(period_s, p["stiffness_n_per_mm"], p["contact_mm"], q1=p["energy_q1"], q2=p["energy_q2"],
                          r=p["energy_r"], correction_limit_mm=p["energy_correction_limit_mm"])


#: the force laws by name, each built from the force controller's parameters
FORCE_LAWS: dict[str, Callable[[Mapping, float, tuple[float, float]], ForceLaw]] = {
    "pi": _pi_law, "energy_optimal": _energy_law}


def make_force_law(name: str, parameters: Mapping, period_s: float, limits_mm: tuple[float, float]) -> ForceLaw:
    """The force law ``name`` (``FORCE_LAWS``) from the controller's parameter values, at
    ``period_s`` with the command limited to ``limits_mm``."""
    if name not in FORCE_LAWS:
        raise ValueError(f"law must be one of {', '.join(FORCE_LAWS)}, got {name!r}")
    return FORCE_LAWS[name](parameters, period_s, limits_mm)
