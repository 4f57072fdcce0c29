"""The plant's telemetry batches checked and turned into robot states (the ``robot_state``
node's behaviour, ROS-free): what a batch must be before any work is spent on it, and which
samples place the machine.

Every input is hostile until checked (docs/graph.md, threat model): the node obeys only the
plant's publishers; behind that door a batch is refused whole, before any conversion, when
its arrays disagree in size, it holds more than ``MAX_BATCH_SAMPLES`` samples (the plant
sends 20: 0.1 s of 5 ms periods; its parameters' ranges allow at most 10 s of 0.1 ms), its
names are not the machine's joints, or a stamp is not finite, negative, beyond what a ROS
stamp holds, or goes back inside the batch. Across batches the timeline must go on: a batch
that starts before the last one placed, or more than ``REJOIN_S`` after it, is held back
until the next batch continues it (a restarted plant's time begins again at 0; one forged
stamp in the past or future moves nothing). With ``every_sample`` at most
``MAX_PLACED_SAMPLES`` of a batch are placed: the forward kinematics per batch is bounded.

Units: time s (the plant's sim time), strut lengths m on the wire, mm in the model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hex_control.kinematics.robot_model import RobotModel, RobotState

MAX_BATCH_SAMPLES = 100_000  # telemetry_period_s <= 10 s over control_period_s >= 1e-4 s (plant_setup.py)
MAX_PLACED_SAMPLES = 1_000  # with every_sample, a batch's FK work (~0.2 ms a sample here) stays under a second
MAX_STAMP_S = 2**31 - 1  # builtin_interfaces/Time holds int32 seconds
REJOIN_S = 5.0  # sim s: the longest step from one batch to the next taken without confirmation


class TelemetryRefused(ValueError):
    """A batch not placed: ``counter`` names the diagnostics counter (``rejected_telemetry``
    malformed, ``stale_telemetry`` off the timeline)."""

    def __init__(self, counter: str, message: str):
        super().__init__(message)
        self.counter = counter


@dataclass(frozen=True)
class Placed:
    """The result of one batch: the states placed (sim time s, state) and the samples whose
    forward kinematics found no pose (sim time s, reason)."""

    states: list[tuple[float, RobotState]]
    failures: list[tuple[float, str]]


def checked_stamps(time_s, max_samples: int = MAX_BATCH_SAMPLES) -> np.ndarray:
    """A batch's sample times (s): 1 to ``max_samples`` of them, finite, within 0 .. 2^31 s
    (a ROS stamp) and in order; TelemetryRefused (``rejected_telemetry``) otherwise."""
    if not 1 <= len(time_s) <= max_samples:  # the size first: nothing is converted before it is known
        raise TelemetryRefused("rejected_telemetry", f"{len(time_s)} samples (1 to {max_samples})")
    times = np.asarray(time_s, float)
    if not (times.ndim == 1 and np.all(np.isfinite(times)) and times[0] >= 0.0 and times[-1] <= MAX_STAMP_S
            and np.all(np.diff(times) >= 0.0)):
        raise TelemetryRefused("rejected_telemetry", "stamps must be finite, within 0 .. 2^31 s and in order")
    return times


class Timeline:
    """Stamps that go on from batch to batch; a jump back or far ahead is taken only when the
    next batch confirms it (continues from where the jump went)."""

    def __init__(self, rejoin_s: float = REJOIN_S):
        self.rejoin_s = rejoin_s
        self.last_s: float | None = None
        self._candidate_s: float | None = None  # where an unconfirmed jump went

    def _continues(self, since_s: float | None, first_s: float) -> bool:
        return since_s is not None and since_s <= first_s <= since_s + self.rejoin_s

    def accept(self, first_s: float, last_s: float) -> bool:
        """Whether a batch from ``first_s`` to ``last_s`` is on the timeline (then it moves it)."""
        if self.last_s is None or self._continues(self.last_s, first_s) or \
                self._continues(self._candidate_s, first_s):
            self.last_s, self._candidate_s = last_s, None
            return True
        self._candidate_s = last_s
        return False


class RobotTelemetry:
    """Robot states from the plant's telemetry batches: the last sample of each, or with
    ``every_sample`` each one (of a batch of more than ``max_placed``, that many evenly
    spaced, the last kept)."""

    def __init__(self, model: RobotModel, *, every_sample: bool = False, max_samples: int = MAX_BATCH_SAMPLES,
                 max_placed: int = MAX_PLACED_SAMPLES):
        self.model, self.every_sample, self.max_samples, self.max_placed = model, every_sample, max_samples, max_placed
        self.joint_names = list(model.machine.joint_names)
        self.timeline = Timeline()

    def place(self, *, time_s, strut_names, strut_lengths_m, deflection_mm) -> Placed:
        """The states of one batch (the message's arrays as they came); empty before the
        plant's first strut command (no lengths yet); TelemetryRefused otherwise."""
        samples, joints = len(time_s), len(self.joint_names)
        if not 1 <= samples <= self.max_samples:  # sizes first: nothing is converted before they agree
            raise TelemetryRefused("rejected_telemetry", f"{samples} samples (1 to {self.max_samples})")
        if len(strut_lengths_m) == 0:
            return Placed([], [])
        if len(deflection_mm) != samples or len(strut_lengths_m) != samples * joints or \
                list(strut_names) != self.joint_names:
            raise TelemetryRefused("rejected_telemetry", f"arrays of {samples} samples of {len(strut_names)} struts "
                                   f"({len(strut_lengths_m)} lengths, {len(deflection_mm)} deflections) for the "
                                   f"machine's {joints} joints {self.joint_names}")
        times = checked_stamps(time_s, self.max_samples)
        if not self.timeline.accept(float(times[0]), float(times[-1])):
            raise TelemetryRefused("stale_telemetry", f"batch at {times[0]:.3f} s does not go on from "
                                   f"{self.timeline.last_s:.3f} s (taken if the next one confirms it)")
        lengths_mm = np.asarray(strut_lengths_m, float).reshape(samples, joints) * 1000.0
        states, failures = [], []
        if not self.every_sample:
            placed = [samples - 1]
        elif samples <= self.max_placed:
            placed = range(samples)
        else:
            placed = np.unique(np.linspace(0, samples - 1, self.max_placed).round().astype(int)).tolist()
        for k in placed:
            try:  # the plant's arrays are in the machine's joint order
                states.append((float(times[k]), self.model.state(lengths_mm[k], float(deflection_mm[k]))))
            except ValueError as error:  # forward kinematics found no pose, or a non-finite sample
                failures.append((float(times[k]), str(error)))
        return Placed(states, failures)
