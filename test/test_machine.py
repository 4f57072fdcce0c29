"""The machine's struts and structural mode (plant): servo following, and the mode that
unshaped moves ring and shaped moves do not (the input shaper's reason to exist)."""

import math

import numpy as np
import pytest

from hex_control.plant.machine import Machine, MachineParameters
from hex_control.shaping.filter import ShaperFilter
from hex_control.shaping.shapers import zvd

STEP_S = 1e-3


def _move(shaped: bool, mode_hz: float = 5.0):
    """All six struts out by 10 mm over a 50 ms ramp, then 3 s of holding; residual deflection."""
    machine = Machine(MachineParameters(mode_frequency_hz=mode_hz), step_s=STEP_S)
    machine.reset(np.full(6, 0.5))
    shaper = ShaperFilter(zvd(5.0, 0.02), STEP_S, channels=6)
    shaper.reset(np.full(6, 0.5))
    deflection = []
    for k in range(4000):
        command = np.full(6, 0.5 + 0.01 * min(k * STEP_S / 0.05, 1.0))
        machine.step(shaper.step(command) if shaped else command)
        deflection.append(machine.deflection_mm)
    return machine, np.array(deflection)


def test_struts_follow_their_commands():
    machine, _ = _move(shaped=False)
    np.testing.assert_allclose(machine.lengths_m, 0.51, atol=1e-9)
    np.testing.assert_allclose(machine.speeds_m_s, 0.0, atol=1e-9)


def test_unshaped_move_rings_the_mode_and_zvd_shaping_cancels_it():
    """Residual deflection after the move: the unshaped ramp rings at 5 Hz; the ZVD-shaped
    one (designed for 5 Hz, damping 0.02) leaves under 5 % of it."""
    _, plain = _move(shaped=False)
    _, shaped = _move(shaped=True)
    tail = slice(1000, None)
    ringing, residual = np.max(np.abs(plain[tail])), np.max(np.abs(shaped[tail]))
    print(f"\nresidual deflection: unshaped {ringing:.3f} mm, ZVD {residual:.4f} mm")
    assert ringing > 0.1
    assert residual < 0.05 * ringing
    spectrum = np.abs(np.fft.rfft(plain[tail]))
    frequency = np.fft.rfftfreq(plain[tail].size, STEP_S)[np.argmax(spectrum)]
    assert frequency == pytest.approx(5.0 * math.sqrt(1 - 0.02**2), abs=0.35)


def test_mode_decays_at_its_damping():
    _, plain = _move(shaped=False)
    peaks = [np.max(np.abs(plain[k:k + 200])) for k in (1000, 3000)]  # 2 s apart = 10 periods
    assert peaks[1] / peaks[0] == pytest.approx(math.exp(-0.02 * 2 * math.pi * 5.0 * 2.0), rel=0.1)


def test_bad_commands_are_refused():
    machine = Machine()
    with pytest.raises(ValueError):
        machine.step(np.full(5, 0.5))
    with pytest.raises(ValueError):
        machine.step(np.array([0.5] * 5 + [math.nan]))


def test_a_period_stepped_at_once_is_bit_for_bit_its_internal_steps():
    """Issue 39: the plant advances the table and the machine a control period at a time
    (``advance``); that must be exactly the internal steps one by one, noise included."""
    from hex_control.plant.force_table import ForceTable, ForceTableParameters

    parameters = ForceTableParameters(runout_mm=0.02, sensor_noise_n=0.3, disk_slowdown_hz_per_n=1.0)
    one_by_one, at_once = ForceTable(parameters, seed=3), ForceTable(parameters, seed=3)
    machines = Machine(MachineParameters()), Machine(MachineParameters())
    rng = np.random.default_rng(0)
    for period in range(400):
        command = float(rng.uniform(-1.0, 1.5))
        struts = 2.5 + 0.01 * rng.normal(size=6)
        if period % 50 == 0:  # the work moves under the disk
            one_by_one.surface_mm = at_once.surface_mm = float(rng.uniform(-0.5, 0.5))
        for _ in range(5):
            one_by_one.step(command)
            machines[0].step(struts)
        at_once.advance(command, 5)
        machines[1].advance(struts, 5)
        assert (at_once.force_n, at_once.measured_n, at_once.position_mm, at_once.disk_phase_rad) == \
            (one_by_one.force_n, one_by_one.measured_n, one_by_one.position_mm, one_by_one.disk_phase_rad)
        assert np.array_equal(machines[1].lengths_m, machines[0].lengths_m)
        assert machines[1].deflection_mm == machines[0].deflection_mm
    assert one_by_one.force_n > 0  # the sequence did touch the work
    with pytest.raises(ValueError):
        at_once.advance(math.nan, 5)
