"""Node ``kinematics``: IK / FK / TestPose / workspace services and the setpoint stream.

Services (hex_control_msgs/srv), all answering with a KinematicsErrorCode:
    ~/inverse_kinematics   ~/test_pose   ~/forward_kinematics   ~/compute_workspace
Trajectories (a pass, handed over whole; DESIGN.md 4.1):
    /motion/tool_path (hex_control_msgs/ToolPath, latched)  in
    /plant/strut_trajectory (trajectory_msgs/JointTrajectory, latched: strut names, lengths
        in m, the path's stamp and sample times)  out
    One vectorized inverse-kinematics call per path; a path with an unreachable or malformed
    pose is refused whole: nothing published, logged with the first bad sample, counted.
Stream (jogging):
    /motion/setpoint (geometry_msgs/PoseStamped, m + quaternion, REP 103)  in
    /plant/strut_command (sensor_msgs/JointState: strut names, lengths in m)  out
    An unreachable or malformed setpoint is refused: nothing published, logged, counted.

Machine from the ``machine_file`` parameter (``config/machines/*.yaml``): ``stewart``
or ``pru3``. For the 3-PRU a pose means (z, roll = alpha, pitch = beta); its x, y and yaw
are the mechanism's parasitic motion and are ignored on input, reported by FK -- except
that a head on a feed stage (``feed_stroke_mm``) reaches the pose's x with the stage,
joint ``feed_x`` after the three sliders.

compute_workspace runs on a companion node with its own executor thread, so a long
workspace request never holds up the other services or the stream (rclpy's
multi-threaded executor proved too slow for the control-rate stream here).
"""

from __future__ import annotations

import math
import threading

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from hex_control.config import config_file
from hex_control.kinematics import load_machine
from hex_control.kinematics.rotation import rpy_from_quaternion
from hex_control.kinematics.stewart import CONSTRAINT_SETS, ForwardKinematicsError
from hex_control.kinematics.workspace import compute_workspace, cross_section
from hex_control.nodes import runtime
from hex_control.nodes.diagnostics import Diagnostics
from hex_control.nodes.interfaces import LATCHED, joint_trajectory_message, tool_path_rows
from hex_control.nodes.message_info import info_subscription
from hex_control.nodes.parameters import ParameterSpec as Spec
from hex_control.nodes.parameters import declare_parameters
from hex_control_msgs.msg import ConstraintReport, KinematicsErrorCode, ToolPath, ToolPose
from hex_control_msgs.srv import ComputeWorkspace, ForwardKinematics, InverseKinematics, TestPose

MAX_POSES = 100_000  # per request
MAX_SECTORS = 50_000
MAX_SLICES = 100  # slice heights per workspace request: about 30 ms each here
Code = KinematicsErrorCode


def _pose_rows(poses) -> np.ndarray:
    return np.array([[p.x_mm, p.y_mm, p.z_mm, p.roll_rad, p.pitch_rad, p.yaw_rad] for p in poses], float)


def _tool_pose(row) -> ToolPose:
    return ToolPose(x_mm=float(row[0]), y_mm=float(row[1]), z_mm=float(row[2]),
                    roll_rad=float(row[3]), pitch_rad=float(row[4]), yaw_rad=float(row[5]))


class KinematicsCore:
    """Request handling shared by the node and its workspace companion: message <-> library."""

    def __init__(self, machine, document: dict):
        self.machine = machine
        self.document = document
        self.joint_names = machine.joint_names
        self.strut_count = len(self.joint_names)

    def joint_positions_mm(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(joint positions (n, joints) mm, reachable (n,)) of n poses, in one vectorized call."""
        return self.machine.joint_positions_mm(rows)

    def reports(self, rows: np.ndarray) -> list[ConstraintReport]:
        check = self.machine.constraint_check(rows)
        ok, margins, reachable = check.satisfied, check.margins, check.reachable
        reports = []
        for k in range(len(rows)):
            report = ConstraintReport(
                reachable=bool(reachable[k]), strut_lengths_ok=bool(ok[k, 0]), platform_joints_ok=bool(ok[k, 1]),
                base_joints_ok=bool(ok[k, 2]), strut_distances_ok=bool(ok[k, 3]),
                strut_length_margin_mm=float(margins[k, 0]), platform_joint_margin_rad=float(margins[k, 1]),
                base_joint_margin_rad=float(margins[k, 2]), strut_distance_margin_mm=float(margins[k, 3]),
                strut_lengths_mm=np.nan_to_num(check.positions_mm[k], nan=0.0).tolist())
            if check.platform_joint_angles_rad is not None:
                report.platform_joint_angles_rad = check.platform_joint_angles_rad[k].tolist()
                report.base_joint_angles_rad = check.base_joint_angles_rad[k].tolist()
            reports.append(report)
        return reports

    def poses_or_error(self, poses) -> tuple[np.ndarray | None, str]:
        if len(poses) > MAX_POSES:
            return None, f"{len(poses)} poses exceed the limit of {MAX_POSES} per request"
        rows = _pose_rows(poses).reshape(-1, 6)
        if not np.all(np.isfinite(rows)):
            return None, "non-finite pose field"
        return rows, ""

    def workspace(self, request, response, logger):
        if not self.machine.maps_workspace:
            response.error_code.val = Code.UNSUPPORTED_MACHINE
            return response
        orientation = np.array([request.roll_rad, request.pitch_rad, request.yaw_rad], float)
        heights = np.asarray(request.slice_heights_mm, float)
        sectors = request.sector_count or 1250
        eps = request.resolution_mm or 1.0
        if (not np.all(np.isfinite(orientation)) or not np.all(np.isfinite(heights)) or heights.size > MAX_SLICES
                or not 18 <= sectors <= MAX_SECTORS or not (0.01 <= eps <= 100.0)
                or np.any(np.abs(orientation) > math.pi)):
            response.error_code.val = Code.INVALID_INPUT
            return response
        n_phi = max(3, round(math.sqrt(sectors / 2)))
        cube = self.document.get("workspace", {}).get("search_cube_mm")
        if cube is None:
            home = self.machine.home_pose[:3]
            cube = [(c - 1000.0, c + 1000.0) for c in home]
        try:
            result = compute_workspace(self.machine, orientation, cube, 2 * n_phi, n_phi, eps)
        except ValueError as exc:  # e.g. nothing reachable at this orientation
            logger.warning(f"workspace: {exc}")
            response.error_code.val = Code.UNREACHABLE
            return response
        points = result.boundary_mm.reshape(-1, 3)
        response.volume_mm3 = result.volume_mm3
        response.center = _tool_pose([*result.center_mm, *orientation])
        response.boundary_x_mm, response.boundary_y_mm, response.boundary_z_mm = (points[:, k].tolist()
                                                                                 for k in range(3))
        response.limiting_constraint = [CONSTRAINT_SETS[s] if s >= 0 else "" for s in result.limiting_set.ravel()]
        response.slice_area_mm2 = [cross_section(self.machine, orientation, z, result.center_mm[:2], 180, eps)[0]
                                   for z in heights]
        response.error_code.val = Code.SUCCESS
        return response


PARAMETERS = {
    "machine_file": Spec(str(config_file("machines/nist_ingersoll.yaml")), "machine YAML (config/machines/)"),
    "quaternion_tolerance": Spec(1e-3, "|1 - |q|| above which a setpoint orientation is malformed", 1e-9, 0.5),
}


class KinematicsNode(Node):
    READY_PARAMETERS = ("machine_file",)  # in its start-up line

    def __init__(self, **kwargs):
        super().__init__("kinematics", **kwargs)
        declare_parameters(self, PARAMETERS)
        self.core = KinematicsCore(*load_machine(self.get_parameter("machine_file").value))
        self.diagnostics = Diagnostics(self)
        self.diagnostics.set("machine", getattr(self.core.machine, "name", "pru3"))
        self.create_service(InverseKinematics, "~/inverse_kinematics", self._on_inverse)
        self.create_service(TestPose, "~/test_pose", self._on_test_pose)
        self.create_service(ForwardKinematics, "~/forward_kinematics", self._on_forward)
        self._command = self.create_publisher(JointState, "plant/strut_command", 100)
        info_subscription(self, PoseStamped, "motion/setpoint", self._on_setpoint, 100, self.diagnostics, "setpoint")
        self._trajectory = self.create_publisher(JointTrajectory, "plant/strut_trajectory", LATCHED)
        self.create_subscription(ToolPath, "motion/tool_path", self._on_path, LATCHED)
        self._names = self.core.joint_names

    def _on_path(self, msg: ToolPath) -> None:
        try:
            rows = tool_path_rows(msg)
        except ValueError as exc:
            self.diagnostics.count("rejected_paths")
            self.get_logger().warning(f"tool path of pass {msg.pass_index} refused: {exc}")
            return
        lengths_mm, reachable = self.core.joint_positions_mm(rows)
        if not reachable.all():
            k = int(np.flatnonzero(~reachable)[0])
            self.diagnostics.count("refused_unreachable_paths")
            self.get_logger().warning(f"tool path of pass {msg.pass_index} of {msg.job_id!r} refused: sample {k} "
                                      f"{rows[k].round(3).tolist()} is out of reach")
            return
        self._trajectory.publish(joint_trajectory_message(msg.header.stamp, self._names, msg.sample_period_s,
                                                          lengths_mm / 1000.0))
        self.diagnostics.count("paths")

    def _fill_reports(self, request, response, service: str) -> bool:
        """Reports for the request's poses into the response; False (and INVALID_INPUT) if refused."""
        rows, problem = self.core.poses_or_error(request.poses)
        if rows is None:
            self.diagnostics.count("rejected_requests")
            self.get_logger().warning(f"{service} refused: {problem}")
            response.error_code.val = Code.INVALID_INPUT
            return False
        response.reports = self.core.reports(rows) if len(rows) else []
        return True

    def _on_inverse(self, request, response):
        if self._fill_reports(request, response, "inverse_kinematics"):
            response.error_code.val = Code.SUCCESS
        return response

    def _on_test_pose(self, request, response):
        response.first_unreachable_index = -1
        if not self._fill_reports(request, response, "test_pose"):
            return response
        unreachable = [k for k, r in enumerate(response.reports) if not r.reachable]
        response.first_unreachable_index = unreachable[0] if unreachable else -1
        response.error_code.val = Code.UNREACHABLE if unreachable else Code.SUCCESS
        return response

    def _on_forward(self, request, response):
        lengths = np.asarray(request.strut_lengths_mm, float)
        guess = _pose_rows([request.initial_guess])[0]
        if (lengths.shape != (self.core.strut_count,) or not np.all(np.isfinite(lengths))
                or not np.all(np.isfinite(guess)) or request.tolerance_mm < 0):
            self.diagnostics.count("rejected_requests")
            response.error_code.val = Code.INVALID_INPUT
            return response
        tolerance = request.tolerance_mm or 1e-9
        iterations = request.max_iterations or 50
        try:
            pose, used, residual = self.core.machine.forward_pose(lengths, guess, tolerance, iterations)
        except ForwardKinematicsError as exc:
            response.error_code.val = Code.SINGULAR if exc.reason == "singular" else Code.NO_CONVERGENCE
            return response
        except ValueError as exc:
            self.get_logger().info(f"forward_kinematics: {exc}")
            response.error_code.val = Code.SINGULAR if "singular" in str(exc) else Code.NO_CONVERGENCE
            return response
        response.pose = _tool_pose(pose)
        response.iterations = int(used)
        response.residual_mm = float(residual)
        response.error_code.val = Code.SUCCESS
        return response

    def _on_setpoint(self, msg: PoseStamped) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        values = np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w], float)
        tolerance = self.get_parameter("quaternion_tolerance").value
        if not np.all(np.isfinite(values)) or abs(1.0 - np.linalg.norm(values[3:])) > tolerance:
            self.diagnostics.count("rejected_malformed")
            self.get_logger().warning("malformed setpoint refused (non-finite or non-unit quaternion)",
                                      throttle_duration_sec=1.0)
            return
        row = np.concatenate([values[:3] * 1000.0, rpy_from_quaternion(*values[3:])])
        if not np.all(np.isfinite(row)):  # finite in m, not in mm (1e306 m)
            self.diagnostics.count("rejected_malformed")
            return
        report = self.core.reports(row[None])[0]
        if not report.reachable:
            self.diagnostics.count("refused_unreachable")
            self.get_logger().warning(f"unreachable setpoint refused: {row.round(3).tolist()}",
                                      throttle_duration_sec=1.0)
            return
        command = JointState()
        command.header.stamp = msg.header.stamp
        command.header.frame_id = "base"
        command.name = self._names
        command.position = [length / 1000.0 for length in report.strut_lengths_mm]
        self._command.publish(command)
        self.diagnostics.count("commands")


class WorkspaceService(Node):
    """Companion node: serves <kinematics node>/compute_workspace from its own thread."""

    def __init__(self, core: KinematicsCore, service_name: str, **kwargs):
        super().__init__("kinematics_workspace", **kwargs)
        self.core = core
        self.create_service(ComputeWorkspace, service_name, self._on_workspace)

    def _on_workspace(self, request, response):
        return self.core.workspace(request, response, self.get_logger())


def main(args=None) -> int:
    import rclpy

    stop = runtime.init(args)
    nodes, executors, worker = [], [], None
    try:
        node = runtime.create_node(KinematicsNode)
        if node is None:
            return 2
        companion = WorkspaceService(node.core, f"{node.get_fully_qualified_name()}/compute_workspace",
                                     namespace=node.get_namespace())
        nodes = [node, companion]
        executors = [runtime.make_executor(), runtime.make_executor()]
        for executor, each in zip(executors, nodes):
            executor.add_node(each)
        worker = threading.Thread(target=runtime.spin_until_stopped, args=(executors[1], stop), daemon=True)
        worker.start()
        node.get_logger().info(runtime.ready_line(node))
        runtime.spin_until_stopped(executors[0], stop)
    finally:
        # the worker leaves its wait set before any executor or node is torn down: shutting
        # down an executor another thread is waiting in can crash the process
        stop.set()
        if worker is not None:
            worker.join(timeout=10.0)
        for executor in executors:
            executor.shutdown(timeout_sec=1.0)
        for each in nodes:
            each.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    main()
