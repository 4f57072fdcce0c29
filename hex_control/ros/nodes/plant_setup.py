"""The plant node's parameters (:mod:`hex_control.ros.nodes.plant`) and the simulated hardware
built from them: machine, force table, workpiece, limits and the pass monitor, wired into a
:class:`~hex_control.plant.core.PlantCore`."""

from __future__ import annotations

import numpy as np

from hex_control.config import DEFAULT_MACHINE_FILE, cell_configuration, config_file
from hex_control.grinding.config import load_pass_planner_config
from hex_control.grinding.contour import Contour, weld_bead
from hex_control.grinding.variation import ProcessVariation
from hex_control.kinematics import load_machine
from hex_control.plant.core import CoreSettings, PlantCore
from hex_control.plant.drives import make_drive
from hex_control.plant.force_table import ForceTableParameters
from hex_control.plant.grinding_cell import GrindingCell
from hex_control.plant.limits import ForceAxisLimits, StrutRateLimiter
from hex_control.plant.lockstep import PLAN_AHEAD_S
from hex_control.plant.machine import MachineParameters
from hex_control.plant.pass_monitor import PassMonitor
from hex_control.plant.pru3_machine import PRU3_SLIDER_DRIVES
from hex_control.plant.simulator import PlantSimulator
from hex_control.plant.tool_locator import ToolLocator
from hex_control.plant.workpiece_store import StoredWorkpiece, load_workpiece
from hex_control.ros.infra.interfaces import MAX_CONTOUR_LENGTH_MM
from hex_control.ros.infra.parameters import ParameterSpec as Spec

_TABLE, _MACHINE, _VARIATION = ForceTableParameters(), MachineParameters(), ProcessVariation()

#: the force table (seed 002 ch. 7), the machine's servos and mode, the process's pass-to-pass variation
TABLE_PARAMETERS = {
    "stiction_n": Spec(_TABLE.stiction_n, "stiction of the table's slide", 0.0, 1000.0),
    "runout_mm": Spec(_TABLE.runout_mm, "disk runout amplitude, once per revolution", 0.0, 5.0),
    "disk_frequency_hz": Spec(_TABLE.disk_frequency_hz, "disk rotation frequency at zero force (Hz)", 5.0, 1000.0),
    "disk_slowdown_hz_per_n": Spec(_TABLE.disk_slowdown_hz_per_n, "air-motor droop of the disk frequency",
                                   0.0, 100.0),
    "sensor_noise_n": Spec(_TABLE.sensor_noise_n, "standard deviation of the force sensor's noise", 0.0, 100.0),
    "sensor_cutoff_hz": Spec(_TABLE.sensor_cutoff_hz, "corner of the force sensor's 2-pole low-pass (Hz)",
                             0.1, 10_000.0),
    "contact_mm": Spec(_TABLE.contact_mm, "table position at which the disk touches the work", -50.0, 50.0),
    "position_loop": Spec(_TABLE.position_loop, "table position loop: eq. 7.3 or eq. 7.2 (App. B)",
                          choices=("two_pole", "third_order")),
}
MACHINE_PARAMETERS = {
    "servo_frequency_hz": Spec(_MACHINE.servo_frequency_hz, "bandwidth of each strut servo (Hz)", 0.1, 10_000.0),
    "servo_damping": Spec(_MACHINE.servo_damping, "damping ratio of each strut servo", 0.01, 10.0),
    "mode_frequency_hz": Spec(_MACHINE.mode_frequency_hz, "frequency of the structural mode (Hz)", 0.1, 10_000.0),
    "mode_damping": Spec(_MACHINE.mode_damping, "damping ratio of the structural mode", 0.0, 10.0),
}
VARIATION_PARAMETERS = {
    "specific_energy_cv": Spec(_VARIATION.specific_energy_cv, "coefficient of variation of K1 pass to pass",
                               0.0, 1.0),
    "friction_cv": Spec(_VARIATION.friction_cv, "coefficient of variation of the friction mu pass to pass",
                        0.0, 1.0),
    "dulling_per_pass": Spec(_VARIATION.dulling_per_pass, "fraction by which K1 grows each pass", 0.0, 1.0),
    "wear_mm_per_pass": Spec(_VARIATION.wear_mm_per_pass, "disk radius lost each pass", 0.0, 100.0),
}
PARAMETERS = {
    "mode": Spec("lockstep", "lockstep: advance on each answering command; realtime: on the wall clock",
                 choices=("lockstep", "realtime")),
    "control_period_s": Spec(0.005, "period of the force loop: one measurement out, one command in", 1e-4, 1.0),
    "internal_step_s": Spec(0.001, "integration step; control_period_s must be a whole number of them",
                            1e-5, 1.0),
    "real_time_factor": Spec(1.0, "sim s per wall s in realtime mode (and of a free-running lock-step)",
                             0.01, 100.0),
    "lockstep_timeout_s": Spec(1.0, "wall time a lock-step waits for a command before it re-sends the state "
                               "(before the first) or advances with the held one (after)", 0.01, 60.0,
                               read_only=False),
    "seed": Spec(0, "seed of the sensor noise and of the process variation", 0, 2**31 - 1),
    "end_time_s": Spec(0.0, "sim time at which the plant stops advancing; 0 = never", 0.0, 1e9),
    "report_file": Spec("", "JSON file of the loop's timing, rewritten every second; '' = none"),
    "clock_period_s": Spec(0.05, "sim time between /clock messages", 0.001, 10.0),
    "telemetry_period_s": Spec(0.1, "sim time batched into one /plant/telemetry message", 0.001, 10.0),
    "debug_streams": Spec(True, "publish true_wrench, deflection and tool_centre every period"),
    "plan_ahead_s": Spec(PLAN_AHEAD_S, "lock-step: sim time run on after a scan while the next pass is planned; "
                         "below the pass planner's start_delay_s less the shaper's lag (0 = stand still)", 0.0, 60.0),
    "controller_status_topic": Spec("force_controller/status", "latched status of the force controller: in "
                                    "lock-step a pass starts only once it holds the pass; '' = do not wait"),
    "table_start_mm": Spec(-1.0, "table position at start-up", -50.0, 50.0),
    "strut_names": Spec([""], "joint names of the struts; [''] = the kinematics node's for the machine"),
    "pru3_drive": Spec("lspd", "3-PRU slider drives: link-space PD or computed torque", choices=PRU3_SLIDER_DRIVES),
    "table_travel_max_mm": Spec(2.0, "the table's far stop: force commands are clamped to "
                                "[retract_mm, table_travel_max_mm]", -50.0, 50.0),
    "overload_n": Spec(cell_configuration().overload_n, "a true normal force above this retracts the table "
                       "(an overload trip; the cell's table.overload_ratio x F_max)", 0.0, 1e5),
    # command ownership (docs/graph.md threat model): one source per input, named relative to the
    # plant's namespace (the cell's); '' = the first publisher heard (only for work by hand)
    "force_command_owner": Spec("force_controller", "node whose force-axis commands the plant obeys"),
    "strut_command_owner": Spec("kinematics", "node whose strut commands and trajectories the plant obeys"),
    "force_trajectory_owner": Spec("pass_planner", "node whose force trajectories announce the passes"),
    "controller_status_owner": Spec("force_controller", "node whose status says which pass it holds"),
    "grinding": Spec(False, "hold a workpiece: a bead ground where the struts put the disk"),
    "machine_file": Spec(str(config_file(DEFAULT_MACHINE_FILE)),
                         "machine YAML (config/machines/); must match the kinematics node's"),
    "pass_planner_config": Spec("pass_planner.yaml", "nominal process, disk and bead frame of the workpiece"),
    "bead_file": Spec("", "bead CSV x_mm,z_mm[,parent_mm]; '' = a generated bead"),
    "workpiece_file": Spec("", "the part as last scanned (JSON), kept across restarts: taken up at start-up "
                           "instead of the bead if it exists, replaced after every scan; '' = none"),
    "bead_length_mm": Spec(300.0, "length of a generated bead", 1.0, MAX_CONTOUR_LENGTH_MM),
    "bead_height_mm": Spec(1.0, "height of a generated bead", 0.0, 50.0),
    "bead_end_ramp_mm": Spec(12.0, "length of a generated bead's end ramps", 0.0, 1000.0),
    "bead_ripple_mm": Spec(0.05, "ripple amplitude of a generated bead", 0.0, 10.0),
    "bead_seed": Spec(0, "seed of a generated bead's ripple", 0, 2**31 - 1),
    "end_zone_mm": Spec(15.0, "length at each bead end that the part-quality figures report apart", 0.0, 1000.0),
    "burn_coefficient": Spec(0.0, "C_B of the burn limit (eq. 5.11), N/sqrt(mm/s); 0 = off", 0.0, 1e6),
    "command_timeout_s": Spec(0.1, "sim age of the last force command after which the table retracts",
                              0.001, 60.0),
    "retract_mm": Spec(-5.0, "the table's retract stop, its near stop", -50.0, 50.0),
    "settle_deflection_mm": Spec(0.01, "a reset move is over when the structure is this still", 1e-6, 10.0),
    "max_settle_s": Spec(10.0, "longest wait for the structure to settle after a pass", 0.0, 600.0),
    **TABLE_PARAMETERS, **MACHINE_PARAMETERS, **VARIATION_PARAMETERS,
}


def build_core(p, outputs, events) -> tuple[PlantCore, StoredWorkpiece | None]:
    """The plant from its parameters (``p(name)`` gives a value): the core, and the workpiece
    it holds (None without ``grinding``). ValueError for settings that do not fit together."""
    period_s = p("control_period_s")
    machine_geometry, machine_document = load_machine(p("machine_file"))
    # the kinematics node's names for the same machine, unless told otherwise
    names = machine_geometry.joint_names
    strut_names = [n for n in p("strut_names") if n] or names
    if len(strut_names) != len(names):
        raise ValueError(f"strut_names: the machine has {len(names)} joints")
    # the disk and its mount are the cell's (config/cell.yaml, through the pass planner's file)
    config = load_pass_planner_config(p("pass_planner_config"), machine_document)
    table = ForceTableParameters(rotational_stiffness_n_mm_rad=config.model.spring_n_mm_rad,
                                 disk_radius_mm=config.model.process.disk_radius_mm,
                                 **{n: p(n) for n in TABLE_PARAMETERS})
    steps = round(period_s / p("internal_step_s"))
    if steps < 1 or abs(steps * p("internal_step_s") - period_s) > 1e-9:
        raise ValueError("control_period_s must be a whole number of internal_step_s")
    machine = make_drive(machine_geometry, MachineParameters(**{n: p(n) for n in MACHINE_PARAMETERS}),
                         p("internal_step_s"), period_s, p("pru3_drive"))
    cell = locator = monitor = workpiece = None
    if p("grinding"):
        workpiece = _workpiece(p)
        variation = ProcessVariation(**{n: p(n) for n in VARIATION_PARAMETERS})
        cell = GrindingCell(workpiece.contour, config.model, variation, p("seed"), table_contact_mm=table.contact_mm,
                            step_mm=config.step_mm,
                            control_period_s=period_s, burn_coefficient=p("burn_coefficient") or None)
        locator = ToolLocator(machine_geometry, config.frame)
        monitor = PassMonitor(cell, p("settle_deflection_mm"), max_settle_s=p("max_settle_s"),
                              command_timeout_s=p("command_timeout_s"), interrupted=workpiece.started)
    speed, acceleration = machine_geometry.joint_speed_max_mm_s, machine_geometry.joint_acceleration_max_mm_s2
    limiter = StrutRateLimiter(speed / 1000.0, acceleration / 1000.0) if np.all(np.isfinite(
        [speed, acceleration])) else None  # a machine file without limits: strokes only
    sim = PlantSimulator(table, machine, p("internal_step_s"), p("seed"), table_start_mm=p("table_start_mm"),
                         cell=cell, locator=locator, strut_limiter=limiter)
    limits = ForceAxisLimits((p("retract_mm"), p("table_travel_max_mm")), p("overload_n"), table.contact_mm)
    settings = CoreSettings(p("mode"), period_s, p("real_time_factor"), p("command_timeout_s"), p("retract_mm"),
                            p("table_start_mm"), p("end_time_s"), bool(p("controller_status_topic")),
                            p("plan_ahead_s"))
    core = PlantCore(settings, sim, axis_limits=limits, outputs=outputs, events=events, strut_names=strut_names,
                     monitor=monitor, check_struts=lambda lengths_m: machine_geometry.check_joint_positions_mm(
                         np.asarray(lengths_m) * 1000.0),
                     check_trajectory=lambda rows_m: machine_geometry.check_joint_trajectory_mm(
                         np.asarray(rows_m) * 1000.0))
    return core, workpiece


def _workpiece(p) -> StoredWorkpiece:
    """The part as last scanned (``workpiece_file``), else a fresh bead (``bead_file`` or generated)."""
    stored = load_workpiece(p("workpiece_file")) if p("workpiece_file") else None
    if stored is not None:
        return stored
    if p("bead_file"):
        bead = Contour.from_csv(p("bead_file"))
    else:
        bead = weld_bead(p("bead_length_mm"), p("bead_height_mm"), p("bead_end_ramp_mm"),
                         ripple_mm=p("bead_ripple_mm"), seed=p("bead_seed"))
    return StoredWorkpiece("", 0, bead)
