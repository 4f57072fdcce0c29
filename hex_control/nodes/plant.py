"""Node ``plant``: the simulated hardware (:class:`hex_control.plant.simulator.PlantSimulator`)
and the source of ``/clock`` -- every other node runs on sim time (use_sim_time:=true).

Modes (``mode``):
- ``lockstep``: after publishing the state at time t the plant waits for the force-axis
  command that answers it (stamped t), then advances one control period. Deterministic for
  a seed when the controller answers every measurement (force_controller
  trigger:=measurement); as fast as the graph allows. A command stamped otherwise (a late
  or repeated answer, a stranger's) is counted (``stale_force_commands``) and does not step
  the loop. Until the first command arrives the state is re-sent every
  ``lockstep_timeout_s`` (the controller answers a re-sent state again: its first answer
  may have gone out before it had matched the plant); after that a timeout advances with
  the held command and is counted.
  With a workpiece (``grinding``) sim time also never outruns the trajectories: the plant
  advances only while a pass runs, or is announced, its strut trajectory is held and the
  force controller says it holds the pass's force trajectory (``controller_status_topic``,
  '' = do not wait for it). Between
  passes the clock stands still while the planners plan, and the time a pass waits for is
  the pass planner's fixed ``start_delay_s``: one seed, one result, at any machine load.
- ``realtime``: advances every control period of wall time divided by ``real_time_factor``
  with the latest command; a period whose measurement went unanswered is a missed cycle. A
  late timer tick steps the periods it owes (:mod:`hex_control.plant.pacing`), so sim time
  keeps pace with the wall clock on a busy machine; late ticks and periods given up are
  reported.
- Either way, force commands older than ``command_timeout_s`` (sim time) drive the table
  to its retract stop ``retract_mm`` (the amplifier's own watchdog: a dead controller cannot
  keep pushing; the stop is far enough back to lift the disk off work that the tool path
  still expects to cut), and in lock-step the plant then runs on in real time until
  commands return.
- Limits below every controller (:mod:`hex_control.plant.limits`): strut commands and
  trajectories outside the machine file's strokes are refused and counted; force commands
  are clamped to the table's travel [``retract_mm``, ``table_travel_max_mm``]; a true force
  above ``overload_n`` retracts the table until a command at or behind the contact resets
  the trip (counted, WARN in ``/diagnostics`` until then).
- Command ownership (:mod:`hex_control.plant.command_owner`): each command input obeys one
  publisher, the first heard or the node named by ``force_command_owner`` /
  ``strut_command_owner``; a restart of that node takes over, others are refused and
  counted (``foreign_*`` in ``/diagnostics``; messages lost on the way: ``lost_*``).
With ``end_time_s`` > 0 the plant stops advancing there (a run of fixed length). Timing
counts from the first answered measurement; ``report_file`` also gets it as JSON every second.
Command latency (measurement out to command in, wall time) and missed cycles are reported
in ``/diagnostics``.

With ``grinding`` true the plant also holds the workpiece (library
:mod:`hex_control.plant.grinding_cell`): a bead (``bead_file`` CSV, or a generated one of
``bead_length_mm`` x ``bead_height_mm``, seed ``bead_seed``), ground where forward kinematics
of the struts puts the disk (``machine_file``, bead frame and nominal process from
``pass_planner_config``), with per-pass variation of the process (``specific_energy_cv``,
``friction_cv``, ``dulling_per_pass``, ``wear_mm_per_pass``, seed ``seed``), burn
(``burn_coefficient`` C_B, 0 = off) and stall detection. Passes are announced by their
force trajectories; after each (machine settled) the scanner publishes the contour and the
pass result (:mod:`hex_control.plant.pass_monitor`). With ``workpiece_file`` the part stays
on the machine across a restart (:mod:`hex_control.plant.workpiece_store`): each scan and its
result go to the file before they are published, and a plant that starts with the file takes
the part up as last scanned, scans it as such (job id, passes) and reports that pass's result
again.

The machine: ``machine_file`` of a Stewart platform drives six generic strut servos
(:mod:`hex_control.plant.machine`); a 3-PRU file drives the head's rigid-body dynamics
(seed 001) under its slider drives, ``pru3_drive`` ``lspd`` or ``ctc``
(:mod:`hex_control.plant.pru3_machine`). Both carry the structural mode.

Topics:
    /clock                      rosgraph_msgs/Clock          out  sim time, every ``clock_period_s``
                                                                  and whenever the plant holds still
    /plant/wrench               geometry_msgs/WrenchStamped  out  sensor force, force.z (N): the loop
    /plant/telemetry            PlantTelemetry               out  every period's state, batched per
                                                                  ``telemetry_period_s`` (while subscribed)
    /plant/strut_states         sensor_msgs/JointState       out  lengths (m), speeds (m/s) (while subscribed)
    /plant/true_wrench          geometry_msgs/WrenchStamped  out  with ``debug_streams``: the true normal
                                                                  force (N), transient-local, last 1000
    /plant/deflection           std_msgs/Float64             out  with ``debug_streams``: structural mode (mm)
    /plant/force_axis_command   hex_control_msgs/ForceAxisCommand in  table position command (mm), stamped
                                                                  with the state it answers
    /plant/strut_trajectory     trajectory_msgs/JointTrajectory in  (latched) strut lengths (m) of a whole
                                                                  move, sampled at every control period
                                                                  once sim time reaches its stamp; one
                                                                  that arrives after its start is refused
    /plant/strut_command        sensor_msgs/JointState       in   jogging: strut lengths (m), applied when
                                                                  sim time reaches the stamp
  with grinding:
    /grinding/contour           hex_control_msgs/Contour     out  the scanned profile after k passes (latched)
    /grinding/pass_result       hex_control_msgs/PassResult  out  one per pass (transient-local, depth 10)
    /plant/tool_centre          geometry_msgs/PointStamped   out  with ``debug_streams``: disk centre in the
                                                                  bead frame (x, H mm in x, z)
    /grinding/force_trajectory  hex_control_msgs/ForceTrajectory in  announces a pass and its timing
    /force_controller/status    diagnostic_msgs/DiagnosticStatus in  (latched) the pass whose force
                                                                  trajectory the controller holds
"""

from __future__ import annotations

import json
import math
import os
import time
from collections import deque

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PointStamped, WrenchStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from trajectory_msgs.msg import JointTrajectory

from hex_control.config import config_file
from hex_control.grinding.config import load_pass_planner_config
from hex_control.grinding.contour import Contour, weld_bead
from hex_control.grinding.part_quality import part_quality
from hex_control.grinding.variation import ProcessVariation
from hex_control.kinematics import load_machine
from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.interfaces import (
    LATCHED,
    MAX_CONTOUR_LENGTH_MM,
    RESULTS,
    STREAM,
    TELEMETRY,
    contour_to_message,
    part_quality_message,
    stamp_s,
    strut_trajectory_from_message,
    time_msg,
)
from hex_control.nodes.message_info import info_subscription
from hex_control.nodes.messages import fill_message, to_primitive
from hex_control.nodes.parameters import ParameterSpec as Spec
from hex_control.nodes.parameters import declare_parameters
from hex_control.nodes.runtime import run_node, wall_timer
from hex_control.plant.drives import make_drive
from hex_control.plant.force_table import ForceTableParameters
from hex_control.plant.grinding_cell import GrindingCell
from hex_control.plant.limits import ForceAxisLimits, StrutRateLimiter
from hex_control.plant.loop_timing import LoopTiming
from hex_control.plant.machine import MachineParameters
from hex_control.plant.pacing import RealTimePacer
from hex_control.plant.pass_monitor import PassMonitor, ScheduledPass
from hex_control.plant.pru3_machine import DRIVES
from hex_control.plant.simulator import PlantSimulator
from hex_control.plant.tool_locator import ToolLocator
from hex_control.plant.workpiece_store import StoredWorkpiece, load_workpiece, save_workpiece
from hex_control_msgs.msg import Contour as ContourMsg
from hex_control_msgs.msg import ForceAxisCommand, ForceTrajectory, PassResult, PlantTelemetry

HELD_TRAJECTORIES = 4  # strut trajectories held at once (the running one and those queued after it)
MISSED_WARN = 0.1  # real time: a fraction of a second's cycles missed beyond which the plant warns
LAG_WARN_S = 0.5  # real time: lag behind the wall clock beyond which the plant warns

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
    "controller_status_topic": Spec("force_controller/status", "latched status of the force controller: in "
                                    "lock-step a pass starts only once it holds the pass; '' = do not wait"),
    "table_start_mm": Spec(-1.0, "table position at start-up", -50.0, 50.0),
    "strut_names": Spec([""], "joint names of the struts; [''] = the kinematics node's for the machine"),
    "pru3_drive": Spec("lspd", "3-PRU slider drives: link-space PD or computed torque", choices=DRIVES),
    "table_travel_max_mm": Spec(2.0, "the table's far stop: force commands are clamped to "
                                "[retract_mm, table_travel_max_mm]", -50.0, 50.0),
    "overload_n": Spec(150.0, "a true normal force above this retracts the table (an overload trip)",
                       0.0, 1e5),
    "force_command_owner": Spec("", "node whose force-axis commands the plant obeys, e.g. /force_controller; "
                                "'' = the first to publish (command ownership, docs/graph.md threat model)"),
    "strut_command_owner": Spec("", "node whose strut commands and trajectories the plant obeys, e.g. "
                                "/kinematics; '' = the first to publish"),
    "grinding": Spec(False, "hold a workpiece: a bead ground where the struts put the disk"),
    "machine_file": Spec(str(config_file("machines/nist_ingersoll.yaml")),
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


class PlantNode(Node):
    READY_PARAMETERS = ("mode", "machine_file", "seed", "grinding")  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("plant", **kwargs)
        declare_parameters(self, PARAMETERS)
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        self.mode = p("mode")
        self.period_s = p("control_period_s")
        machine_geometry, machine_document = load_machine(p("machine_file"))
        # the kinematics node's names for the same machine, unless told otherwise
        names = machine_geometry.joint_names
        self.strut_names = [n for n in p("strut_names") if n] or names
        if len(self.strut_names) != len(names):
            raise ValueError(f"strut_names: the machine has {len(names)} joints")
        # the disk and its mount are the cell's (config/cell.yaml, through the pass planner's file)
        config = load_pass_planner_config(p("pass_planner_config"), machine_document)
        table = ForceTableParameters(rotational_stiffness_n_mm_rad=config.model.spring_n_mm_rad,
                                     disk_radius_mm=config.model.process.disk_radius_mm,
                                     **{n: p(n) for n in TABLE_PARAMETERS})
        steps = round(self.period_s / p("internal_step_s"))
        if steps < 1 or abs(steps * p("internal_step_s") - self.period_s) > 1e-9:
            raise ValueError("control_period_s must be a whole number of internal_step_s")
        machine = make_drive(machine_geometry, MachineParameters(**{n: p(n) for n in MACHINE_PARAMETERS}),
                             p("internal_step_s"), self.period_s, p("pru3_drive"))
        cell, locator, self.monitor = None, None, None
        if p("grinding"):
            cell, locator = self._cell(machine_geometry, config, table.contact_mm)
            self.monitor = PassMonitor(cell, p("settle_deflection_mm"), max_settle_s=p("max_settle_s"),
                                       command_timeout_s=p("command_timeout_s"))
        speed, acceleration = machine_geometry.joint_speed_max_mm_s, machine_geometry.joint_acceleration_max_mm_s2
        limiter = StrutRateLimiter(speed / 1000.0, acceleration / 1000.0) if np.all(np.isfinite(
            [speed, acceleration])) else None  # a machine file without limits: strokes only
        self.sim = PlantSimulator(table, machine, p("internal_step_s"), p("seed"), p("table_start_mm"), cell, locator,
                                  limiter)
        self.axis_limits = ForceAxisLimits((p("retract_mm"), p("table_travel_max_mm")), p("overload_n"),
                                           table.contact_mm)
        self.check_struts = lambda lengths_m: machine_geometry.check_joint_positions_mm(np.asarray(lengths_m) * 1000.0)
        self.command_mm = p("table_start_mm")
        self.last_command_s = 0.0  # sim time of the latest force command
        self.free_running = False  # lock-step whose controller stopped answering
        self.strut_queue = deque()  # (stamp s, lengths m) of commands stamped ahead of sim time
        self.trajectories = []  # StrutTrajectory, by start
        self.answer_ready = False  # lock-step: the command answering the last state is in hand
        self.holding = False  # lock-step: standing still until a pass is covered
        self.next_clock_s = 0.0
        self.telemetry = []  # (time s, measured N, true N, table mm, deflection mm, x mm, H mm, lengths m)
        self.debug_streams = p("debug_streams")
        self.timing = LoopTiming()
        self._paced = (0, 0)  # cycles, missed at the last report
        self.started = False  # a first command has answered a measurement
        self.loop_start = self.loop_end = None
        self.diagnostics = Diagnostics(self)
        self.clock_publisher = self.create_publisher(Clock, "clock", 10)  # /clock, or the cell's under its namespace
        self.wrench_publisher = self.create_publisher(WrenchStamped, "plant/wrench", 100)
        # transient-local: a late joiner (a logger, a test) still gets the last 1000 states
        self.truth_publisher = self.create_publisher(WrenchStamped, "plant/true_wrench", QoSProfile(
            depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.strut_publisher = self.create_publisher(JointState, "plant/strut_states", 100)
        self.deflection_publisher = self.create_publisher(Float64, "plant/deflection", 100)
        for topic, msg_type, callback, qos, owner, name in (
                ("plant/force_axis_command", ForceAxisCommand, self._on_force_command, 100, "force_command_owner",
                 "force_command"),
                ("plant/strut_command", JointState, self._on_strut_command, 100, "strut_command_owner",
                 "strut_command"),
                ("plant/strut_trajectory", JointTrajectory, self._on_strut_trajectory, LATCHED,
                 "strut_command_owner", "strut_trajectory")):
            info_subscription(self, msg_type, topic, callback, qos, self.diagnostics, name, p(owner))
        # kept (transient-local, the last 100 batches): a late observer still learns where the plant holds
        self.telemetry_publisher = self.create_publisher(PlantTelemetry, "plant/telemetry", TELEMETRY)
        if self.monitor is not None:
            self.contour_publisher = self.create_publisher(ContourMsg, "grinding/contour", LATCHED)
            self.result_publisher = self.create_publisher(PassResult, "grinding/pass_result", RESULTS)
            self.centre_publisher = self.create_publisher(PointStamped, "plant/tool_centre", STREAM)
            self.create_subscription(ForceTrajectory, "grinding/force_trajectory", self._on_trajectory, LATCHED)
            self.controller_holds = deque(maxlen=HELD_TRAJECTORIES)  # (job_id, pass_index) the controller has
            if p("controller_status_topic"):
                self.create_subscription(DiagnosticStatus, p("controller_status_topic"), self._on_controller_status,
                                         LATCHED)
            self.contour_publisher.publish(self._contour_message(cell.contour, self.workpiece.job_id,
                                                                 self.workpiece.passes))
            if self.workpiece.last_result is not None:  # the same message again, in case nobody had taken it in
                self.result_publisher.publish(fill_message(PassResult(), self.workpiece.last_result))
        if self.mode == "realtime":
            self.pacer = RealTimePacer(self.period_s, p("real_time_factor"))
            self.create_timer(self.period_s / p("real_time_factor"), self._realtime_tick)
        else:
            self.create_timer(p("lockstep_timeout_s") / 4, self._lockstep_watchdog)
            self.create_timer(self.period_s / p("real_time_factor"), self._free_run)
        wall_timer(self, 1.0, self._report)
        self._publish_state()

    def _cell(self, machine_geometry, config, contact_mm: float) -> tuple[GrindingCell, ToolLocator]:
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        self.workpiece = load_workpiece(p("workpiece_file")) if p("workpiece_file") else None
        if self.workpiece is not None:
            self.get_logger().info(f"took up the workpiece of {p('workpiece_file')}: {self.workpiece.passes} passes "
                                   f"of job {self.workpiece.job_id or '(none)'}")
        elif p("bead_file"):
            bead = Contour.from_csv(p("bead_file"))
        else:
            bead = weld_bead(p("bead_length_mm"), p("bead_height_mm"), p("bead_end_ramp_mm"),
                             ripple_mm=p("bead_ripple_mm"), seed=p("bead_seed"))
        if self.workpiece is None:
            self.workpiece = StoredWorkpiece("", 0, bead)
        bead = self.workpiece.contour
        variation = ProcessVariation(**{n: p(n) for n in VARIATION_PARAMETERS})
        cell = GrindingCell(bead, config.model, variation, p("seed"), contact_mm, config.step_mm,
                            self.period_s, p("burn_coefficient") or None)
        return cell, ToolLocator(machine_geometry, config.frame)

    def _contour_message(self, contour: Contour, job_id: str, passes: int):
        msg = contour_to_message(contour, job_id, passes, self.sim.cell.width_mm)
        msg.header.stamp = time_msg(self.sim.time_s)  # the pass planner starts the next pass from here
        return msg

    def _on_trajectory(self, msg: ForceTrajectory) -> None:
        grind_start = stamp_s(msg.header.stamp)
        try:
            if not msg.time_from_start_s or grind_start < 0:
                raise ValueError("empty trajectory or negative stamp")
            scheduled = ScheduledPass(msg.job_id, msg.pass_index, grind_start + msg.path_start_s, grind_start,
                                      grind_start + msg.time_from_start_s[-1], grind_start + msg.path_end_s)
            if self.monitor.schedule(scheduled):
                self.diagnostics.count("passes_announced")
        except ValueError as error:
            self.diagnostics.count("rejected_trajectory")
            self.get_logger().warning(f"force trajectory rejected: {error}")
        self._lockstep_step()

    def _on_controller_status(self, msg: DiagnosticStatus) -> None:
        values = {pair.key: pair.value for pair in msg.values}
        if msg.message != "trajectory" or not values.get("pass_index", "").isdigit():
            self.diagnostics.count("ignored_controller_status")
            return
        self.controller_holds.append((values.get("job_id", ""), int(values["pass_index"])))
        self._lockstep_step()

    def _on_strut_trajectory(self, msg: JointTrajectory) -> None:
        try:
            trajectory = strut_trajectory_from_message(msg, self.strut_names)
            for lengths in trajectory.lengths_m:
                self.check_struts(lengths)
        except ValueError as error:
            self.diagnostics.count("rejected_strut_trajectory")
            self.get_logger().warning(f"strut trajectory rejected: {error}", throttle_duration_sec=1.0)
            return
        if trajectory.start_s < self.sim.time_s - 1e-9:  # never jump into a move part-way
            self.diagnostics.count("late_strut_trajectory")
            self.get_logger().warning(f"strut trajectory from {trajectory.start_s:.3f} s refused: it arrived at "
                                      f"{self.sim.time_s:.3f} s", throttle_duration_sec=1.0)
            return
        # a trajectory replaces whatever the held ones would do from its start on
        kept = [t for t in self.trajectories if t.start_s < trajectory.start_s - 1e-9]
        self.trajectories = (kept + [trajectory])[-HELD_TRAJECTORIES:]
        self.diagnostics.count("strut_trajectories")
        self._lockstep_step()

    # -- inputs ----------------------------------------------------------------------------
    def _on_force_command(self, msg: ForceAxisCommand) -> None:
        if not math.isfinite(msg.position_mm):
            self.diagnostics.count("rejected_force_command")
            return
        if self.mode == "lockstep" and not self.free_running and msg.header.stamp != time_msg(self.sim.time_s):
            self.diagnostics.count("stale_force_commands")  # it answers another state than the one waiting
            return
        self.command_mm = msg.position_mm
        self.last_command_s, self.free_running = self.sim.time_s, False
        self.diagnostics.clear("free_running")
        now = time.monotonic()
        answered = self.timing.answered(now)
        if answered and not self.started:
            self.started, self.loop_start = True, now
            self.timing = LoopTiming()  # count from here: startup is not the loop
        if self.mode == "lockstep":
            if answered:
                self.answer_ready = True
                self._lockstep_step()
            else:
                self.diagnostics.count("unsolicited_commands")

    def _on_strut_command(self, msg: JointState) -> None:
        try:
            positions = dict(zip(msg.name, msg.position)) if msg.name else dict(zip(self.strut_names, msg.position))
            lengths = [positions[name] for name in self.strut_names]
            if not all(math.isfinite(v) for v in lengths):
                raise ValueError(f"strut lengths must be finite, got {lengths}")
            self.check_struts(lengths)
        except (KeyError, ValueError) as error:
            self.diagnostics.count("rejected_strut_command")
            self.get_logger().warning(f"strut command rejected: {error}", throttle_duration_sec=1.0)
            return
        stamp = stamp_s(msg.header.stamp)
        if stamp <= self.sim.time_s:
            self.sim.command_struts(lengths)
        elif self.strut_queue and stamp < self.strut_queue[-1][0] or len(self.strut_queue) >= 10000:
            self.diagnostics.count("rejected_strut_command")  # out of order, or a flood
        else:  # a path streamed ahead: apply it when its time comes (deterministic in lock-step)
            self.strut_queue.append((stamp, lengths))

    # -- stepping --------------------------------------------------------------------------
    def _covered(self) -> bool:
        """May sim time advance? Always, but in lock-step with a workpiece: only while a pass
        runs, or is announced with the strut trajectory that starts it held and its force
        trajectory in the controller's hands."""
        if self.mode != "lockstep" or self.monitor is None or self.monitor.running is not None:
            return True
        scheduled = self.monitor.scheduled
        # the motion of the whole pass in hand: a strut trajectory from the path's start (or
        # earlier: a shaped path starts its shaper's lag early) to its end
        if scheduled is None or not any(t.start_s <= scheduled.path_start_s + 1e-6 and t.end_s >= scheduled.path_end_s
                                        for t in self.trajectories):
            return False
        return (not self.get_parameter("controller_status_topic").value
                or (scheduled.job_id, scheduled.pass_index) in self.controller_holds)

    def _lockstep_step(self) -> None:
        if self.mode != "lockstep" or not self.answer_ready:
            return
        if self._covered():
            self.answer_ready = False
            self._advance()
        elif not self.holding:  # standing still: say where, to whoever subscribes later too
            self.holding = True
            self._record_telemetry(self.sim.snapshot(), always=True)
            self._flush_telemetry()
            self.clock_publisher.publish(Clock(clock=time_msg(self.sim.time_s)))

    def _apply_strut_commands(self) -> None:
        now = self.sim.time_s + 1e-9
        while self.strut_queue and self.strut_queue[0][0] <= now:
            self.sim.command_struts(self.strut_queue.popleft()[1])
        self.trajectories = [t for t in self.trajectories if t.end_s > now - self.period_s]
        active = [t for t in self.trajectories if t.start_s <= now]
        if active:
            self.sim.command_struts(active[-1].at(self.sim.time_s))

    def _advance(self) -> None:
        end = self.get_parameter("end_time_s").value
        if 0 < end <= self.sim.time_s + 1e-9:
            self.loop_end = self.loop_end or time.monotonic()
            return  # the run is over: hold still
        self.holding = False
        self.timing.cycle()
        command_age_s = self.sim.time_s - self.last_command_s
        if command_age_s > self.get_parameter("command_timeout_s").value:
            self.command_mm = self.get_parameter("retract_mm").value  # amplifier watchdog
        self._apply_strut_commands()
        command_mm = self._limited_command()
        limiter = self.sim.strut_limiter
        limited = limiter.limited if limiter is not None else 0
        try:
            state = self.sim.advance(self.period_s, command_mm)
        except ValueError as error:  # the tool left the machine's forward kinematics
            self.diagnostics.count("simulation_errors")
            self.get_logger().error(f"plant step failed: {error}", throttle_duration_sec=1.0)
            return
        if limiter is not None and limiter.limited > limited:
            self.diagnostics.count("limited_strut_commands")  # a strut command beyond the servos' speed or acceleration
        if self.monitor is not None:
            self._monitor_pass(state, command_age_s)
        self._publish_state()

    def _limited_command(self) -> float:
        """The force command within the table's travel, or the retract stop while tripped."""
        limits = self.axis_limits
        clamped, trips, tripped = limits.clamped, limits.trips, limits.tripped
        command_mm = limits.command_mm(self.command_mm, self.sim.table.force_n)
        if tripped and not limits.tripped:
            self.diagnostics.count("overload_resets")
            self.diagnostics.clear("overload")
        if limits.clamped > clamped:
            self.diagnostics.count("clamped_force_commands")
        if limits.trips > trips:
            self.diagnostics.count("overload_trips")
            self.diagnostics.fault("overload", f"overload: {self.sim.table.force_n:.0f} N > {limits.overload_n:g} N, "
                                   "table retracted until the command asks for no force")
            self.get_logger().error(f"overload trip at {self.sim.table.force_n:.0f} N: table retracted")
        return command_mm

    def _monitor_pass(self, state, command_age_s: float) -> None:
        report = self.monitor.on_period(state.time_s, state.deflection_mm, state.strut_speeds_m_s, command_age_s)
        if report is None:
            return
        m = report.measurement
        end_zone_mm = min(self.get_parameter("end_zone_mm").value, m.contour_after.length_mm / 2)
        self.contour_publisher.publish(self._contour_message(m.contour_after, m.job_id, m.pass_index + 1))
        result = PassResult(job_id=m.job_id, pass_index=m.pass_index,
                            status=PassResult.ABORTED if report.aborted else PassResult.COMPLETED,
                            reason=report.reason, measured_cut_depth_mm=m.measured_cut_depth_mm,
                            removed_volume_mm3=m.removed_volume_mm3, duration_s=report.duration_s,
                            mean_normal_force_n=m.mean_normal_force_n, peak_normal_force_n=m.peak_normal_force_n,
                            feed_speed_mm_s=m.mean_feed_mm_s, specific_energy_j_mm3=m.specific_energy_j_mm3,
                            cut_depth_coefficient=(m.measured_cut_depth_mm * m.mean_feed_mm_s / m.mean_normal_force_n
                                                   if m.mean_normal_force_n > 0 else 0.0),
                            burn_detected=m.burn_detected, stall_detected=m.stall_detected,
                            part_quality=part_quality_message(part_quality(m.contour_after, end_zone_mm), end_zone_mm))
        result.header.stamp = time_msg(state.time_s)
        if self.get_parameter("workpiece_file").value:  # on disk before anyone hears of it
            self.workpiece = StoredWorkpiece(m.job_id, m.pass_index + 1, m.contour_after, to_primitive(result))
            save_workpiece(self.get_parameter("workpiece_file").value, self.workpiece)
        self.result_publisher.publish(result)
        self.diagnostics.count("passes_aborted" if report.aborted else "passes_completed")
        if m.burn_detected or m.stall_detected:  # until a pass without
            what = "burn" if m.burn_detected else "stall"
            self.diagnostics.fault("last_pass", f"pass {m.pass_index}: {what} detected")
        else:
            self.diagnostics.clear("last_pass")
        self.get_logger().info(f"pass {m.pass_index} of {m.job_id}: cut {m.measured_cut_depth_mm:.4f} mm, "
                               f"{report.duration_s:.2f} s{', ABORTED: ' + report.reason if report.aborted else ''}")

    def _lockstep_watchdog(self) -> None:
        pending = self.timing.pending_since_s
        if pending is None or time.monotonic() - pending < self.get_parameter("lockstep_timeout_s").value:
            return
        if not self.started:
            self._publish_state()  # nobody answered yet: say it again
            return
        self.diagnostics.count("lockstep_timeouts")
        self.free_running = True
        self.diagnostics.fault("free_running", "lock-step: the controller stopped answering, running on the wall "
                                               "clock with the held command")
        if self._covered():
            self._advance()

    def _realtime_tick(self) -> None:
        for _ in range(self.pacer.due(time.monotonic())):
            self._advance()

    def _free_run(self) -> None:
        if self.free_running and self._covered():
            self._advance()

    def _publish_state(self) -> None:
        state = self.sim.snapshot()
        stamp = time_msg(state.time_s)
        if state.time_s >= self.next_clock_s - 1e-9:
            self.clock_publisher.publish(Clock(clock=stamp))
            period = self.get_parameter("clock_period_s").value
            self.next_clock_s = (math.floor(state.time_s / period + 1e-6) + 1) * period
        wrench = WrenchStamped()
        wrench.header.stamp, wrench.header.frame_id = stamp, "tool"
        wrench.wrench.force.z = state.measured_force_n
        self.wrench_publisher.publish(wrench)
        self._record_telemetry(state)
        if self.debug_streams:
            truth = WrenchStamped()
            truth.header.stamp, truth.header.frame_id = stamp, "tool"
            truth.wrench.force.z = state.force_n
            self.truth_publisher.publish(truth)
        if state.strut_lengths_m is not None:
            if self.strut_publisher.get_subscription_count():
                joints = JointState(name=self.strut_names, position=state.strut_lengths_m.tolist(),
                                    velocity=state.strut_speeds_m_s.tolist())
                joints.header.stamp = stamp
                self.strut_publisher.publish(joints)
            if self.debug_streams:
                self.deflection_publisher.publish(Float64(data=state.deflection_mm))
        if state.centre_mm is not None and self.debug_streams:
            centre = PointStamped()
            centre.header.stamp, centre.header.frame_id = stamp, "bead"
            centre.point.x, centre.point.z = state.centre_mm
            self.centre_publisher.publish(centre)
        self.timing.sent(time.monotonic())

    def _record_telemetry(self, state, always: bool = False) -> None:
        if not (always or self.telemetry_publisher.get_subscription_count()):
            self.telemetry.clear()
            return
        if self.telemetry and self.telemetry[-1][0] == state.time_s:
            return  # the same state sent again (lock-step start-up)
        centre = state.centre_mm or (math.nan, math.nan)
        self.telemetry.append((state.time_s, state.measured_force_n, state.force_n, state.table_position_mm,
                               state.deflection_mm, *centre, state.strut_lengths_m))
        if len(self.telemetry) * self.period_s >= self.get_parameter("telemetry_period_s").value - 1e-9:
            self._flush_telemetry()

    def _flush_telemetry(self) -> None:
        if not self.telemetry:
            return
        samples, self.telemetry = self.telemetry, []
        columns = list(zip(*samples))
        msg = PlantTelemetry(strut_names=self.strut_names, time_s=list(columns[0]), measured_force_n=list(columns[1]),
                             true_force_n=list(columns[2]), table_position_mm=list(columns[3]),
                             deflection_mm=list(columns[4]), centre_x_mm=list(columns[5]),
                             centre_height_mm=list(columns[6]))
        if all(lengths is not None for lengths in columns[7]):
            msg.strut_lengths_m = np.concatenate(columns[7]).tolist()
        msg.header.stamp = time_msg(samples[-1][0])
        self.telemetry_publisher.publish(msg)

    def _judge_pace(self, lag_s: float) -> None:
        """Real time: WARN while the last second missed over MISSED_WARN of its cycles or
        the plant lags the wall clock by over LAG_WARN_S; it clears when both recover."""
        cycles, missed = self.timing.cycles, self.timing.missed
        if cycles < self._paced[0]:  # the count restarted with the first answer
            self._paced = (0, 0)
        recent_cycles, recent_missed = cycles - self._paced[0], missed - self._paced[1]
        self._paced = (cycles, missed)
        missed_fraction = recent_missed / recent_cycles if recent_cycles else 0.0
        if missed_fraction > MISSED_WARN or lag_s > LAG_WARN_S:
            self.diagnostics.fault("pace", f"behind real time: {missed_fraction:.0%} of the last second's cycles "
                                           f"missed, {lag_s * 1e3:.0f} ms late")
        else:
            self.diagnostics.clear("pace")

    def _report(self) -> None:
        wall = (self.loop_end or time.monotonic()) - self.loop_start if self.loop_start is not None else math.nan
        p50, p99 = self.timing.latency_percentiles_ms()
        report = {"sim_time_s": self.sim.time_s, "cycles": self.timing.cycles,
                  "loop_rate_hz": self.timing.cycles / wall if wall > 0 else math.nan,
                  "missed_fraction": self.timing.missed_fraction, "latency_p50_ms": p50, "latency_p99_ms": p99}
        if self.mode == "realtime":
            report.update(late_ticks=self.pacer.late_ticks, dropped_periods=self.pacer.dropped,
                          real_time_lag_ms=self.pacer.lag_s(time.monotonic()) * 1e3)
            self._judge_pace(report["real_time_lag_ms"] * 1e-3)
        for name, value in report.items():
            self.diagnostics.set(name, f"{value:.4g}")
        path = self.get_parameter("report_file").value
        if path:
            with open(path + ".tmp", "w") as stream:
                json.dump(report, stream)
            os.replace(path + ".tmp", path)


def main(args=None) -> int:
    return run_node(PlantNode, args)


if __name__ == "__main__":
    main()
