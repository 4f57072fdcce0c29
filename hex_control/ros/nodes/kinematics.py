"""Node ``kinematics``: IK / FK / TestPose / workspace services and the relays to the plant
(behaviour: :class:`hex_control.kinematics.service.KinematicsCore`).

Services (hex_control_msgs/srv), all answering with a KinematicsErrorCode:
    ~/inverse_kinematics   ~/test_pose   ~/forward_kinematics   ~/compute_workspace
    IK and TestPose take at most ``max_poses`` poses, refused before they are converted.
A pass, handed over whole (DESIGN.md 4.1), and the jogging stream:
    /motion/tool_path (ToolPath, latched, from ``tool_path_owner`` only)  in
    /plant/strut_trajectory (JointTrajectory, latched: strut lengths in m)  out
    /motion/setpoint (PoseStamped, m + quaternion, REP 103, from ``setpoint_owner`` only)  in
    /plant/strut_command (JointState: strut lengths in m)  out
A refused path, setpoint or request is logged and counted; another node's path or setpoint
is counted as ``foreign_tool_path`` / ``foreign_setpoint``: the plant obeys this node's
strut commands, so it relays only its configured owner's (by default the input shaper;
jog by hand through the shaper's setpoint_raw).

The heavy services (compute_workspace, inverse_kinematics, test_pose) are served by
companion nodes in this process, each on its own executor thread (an executor owns whole
nodes): a long request holds up neither FK, the relays, nor the other heavy services.
"""

from __future__ import annotations

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from hex_control.kinematics import load_machine
from hex_control.kinematics.service import KinematicsCore, KinematicsSettings, PoseAnswer, Relay
from hex_control.ros.infra import runtime
from hex_control.ros.infra.diagnostics import Diagnostics
from hex_control.ros.infra.interfaces import LATCHED, joint_trajectory_message, tool_path_rows
from hex_control.ros.infra.message_info import info_subscription
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.nodes.kinematics_messages import constraint_reports, pose_rows, tool_pose
from hex_control_msgs.msg import KinematicsErrorCode, ToolPath
from hex_control_msgs.srv import ComputeWorkspace, ForwardKinematics, InverseKinematics, TestPose

#: latched paths in, 10 deep: another publisher's burst must not push the owner's path out
#: of a depth-1 reader queue before it is taken (the burst is refused, the pass left pathless)
PATHS_IN = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
Code = KinematicsErrorCode
DEFAULTS = KinematicsSettings()
OWNER = "(a node name, relative ones resolved in this node's namespace; '' = the first publisher heard)"
PARAMETERS = {
    "machine_file": Spec(DEFAULTS.machine_file, "machine YAML (config/machines/)"),
    "quaternion_tolerance": Spec(DEFAULTS.quaternion_tolerance, "|1 - |q|| above which a setpoint orientation "
                                 "is malformed", 1e-9, 0.5),
    "max_poses": Spec(DEFAULTS.max_poses, "poses per IK / TestPose request; more are refused before conversion. "
                      "Measured on this 2-core machine near idle (NIST hexapod, request and answer through rclpy): "
                      "40,000-50,000 poses/s, 25,000 poses 0.5-0.65 s a round trip: under 1 s", 1, 1_000_000),
    "setpoint_owner": Spec(DEFAULTS.setpoint_owner, f"whose motion/setpoint poses are relayed {OWNER}"),
    "tool_path_owner": Spec(DEFAULTS.tool_path_owner, f"whose motion/tool_path is converted {OWNER}"),
}


class Companion(Node):
    """Serves one heavy service of the kinematics node, spun by an executor of its own."""

    def __init__(self, name: str, srv_type, service: str, handler, **kwargs):
        super().__init__(name, **kwargs)
        self.create_service(srv_type, service, handler)


class KinematicsNode(Node):
    # An FK answer takes dozens of GIL hand-overs from a heavy request's thread, each up to the
    # switch interval (5 ms by default): 0.25 ms makes it several times quicker
    SWITCH_INTERVAL_S = 0.00025
    READY_PARAMETERS = ("machine_file", "max_poses", "setpoint_owner", "tool_path_owner")  # in its start-up line
    HEAVY = (("kinematics_workspace", ComputeWorkspace, "compute_workspace", "_on_workspace"),
             ("kinematics_inverse", InverseKinematics, "inverse_kinematics", "_on_inverse"),
             ("kinematics_test_pose", TestPose, "test_pose", "_on_test_pose"))

    def __init__(self, **kwargs):
        super().__init__("kinematics", **kwargs)
        declare_parameters(self, PARAMETERS)
        self.settings = KinematicsSettings(**{name: self.get_parameter(name).value for name in PARAMETERS})
        self.core = KinematicsCore(*load_machine(self.settings.machine_file), self.settings)
        self.diagnostics = Diagnostics(self)
        self.diagnostics.set("machine", self.core.machine.name)
        self.create_service(ForwardKinematics, "~/forward_kinematics", self._on_forward)
        self._command = self.create_publisher(JointState, "plant/strut_command", 100)
        info_subscription(self, PoseStamped, "motion/setpoint", self._on_setpoint, 100, diagnostics=self.diagnostics,
                          name="setpoint", owner_node=self.settings.setpoint_owner)
        self._trajectory = self.create_publisher(JointTrajectory, "plant/strut_trajectory", LATCHED)
        info_subscription(self, ToolPath, "motion/tool_path", self._on_path, PATHS_IN, diagnostics=self.diagnostics,
                          name="tool_path", owner_node=self.settings.tool_path_owner)

    def companions(self) -> list[Companion]:
        """The nodes that serve the heavy services under this node's name (spin each apart)."""
        return [Companion(name, kind, f"{self.get_fully_qualified_name()}/{service}", getattr(self, handler),
                          namespace=self.get_namespace(), context=self.context) for name, kind, service, handler in
                self.HEAVY]

    def _refused(self, what: str, verdict, counter: str = "rejected_requests") -> None:
        self.diagnostics.count(counter)
        self.get_logger().warning(f"{what} refused: {verdict.reason}", throttle_duration_sec=1.0)

    def _on_path(self, msg: ToolPath) -> None:
        try:
            relay = self.core.strut_trajectory(tool_path_rows(msg))
        except ValueError as exc:
            relay = Relay(None, "rejected_paths", str(exc))
        if relay.positions_mm is None:
            return self._refused(f"tool path of pass {msg.pass_index} of {msg.job_id!r}", relay, relay.counter)
        self._trajectory.publish(joint_trajectory_message(msg.header.stamp, self.core.joint_names,
                                                          msg.sample_period_s, relay.positions_mm / 1000.0))
        self.diagnostics.count(relay.counter)

    def _on_setpoint(self, msg: PoseStamped) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        relay = self.core.setpoint((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
        if relay.positions_mm is None:
            return self._refused("setpoint", relay, relay.counter)
        command = JointState(name=self.core.joint_names, position=(relay.positions_mm / 1000.0).tolist())
        command.header.stamp, command.header.frame_id = msg.header.stamp, "base"
        self._command.publish(command)
        self.diagnostics.count(relay.counter)

    def _poses(self, request, response, solve, service: str):
        refusal = self.core.pose_count_refusal(len(request.poses))  # before a single pose is converted
        answer = PoseAnswer("INVALID_INPUT", reason=refusal) if refusal else solve(pose_rows(request.poses))
        if answer.check is None:
            self._refused(service, answer)
        else:
            response.reports = constraint_reports(answer.check)
        response.error_code.val = getattr(Code, answer.outcome)
        if hasattr(response, "first_unreachable_index"):  # TestPose
            response.first_unreachable_index = answer.first_unreachable
        return response

    def _on_inverse(self, request, response):
        return self._poses(request, response, self.core.inverse, "inverse_kinematics")

    def _on_test_pose(self, request, response):
        return self._poses(request, response, self.core.test_pose, "test_pose")

    def _on_forward(self, request, response):
        answer = self.core.forward(request.strut_lengths_mm, pose_rows([request.initial_guess])[0],
                                   request.tolerance_mm, request.max_iterations)
        response.error_code.val = getattr(Code, answer.outcome)
        if answer.outcome == "INVALID_INPUT":
            self._refused("forward_kinematics", answer)
        elif answer.pose is not None:
            response.pose, response.iterations = tool_pose(answer.pose), answer.iterations
            response.residual_mm = answer.residual_mm
        return response

    def _on_workspace(self, request, response):
        answer = self.core.workspace((request.roll_rad, request.pitch_rad, request.yaw_rad), request.slice_heights_mm,
                                     request.sector_count, request.resolution_mm)
        response.error_code.val = getattr(Code, answer.outcome)
        if answer.outcome != "SUCCESS":
            self.get_logger().warning(f"compute_workspace: {answer.reason}")
            return response
        response.volume_mm3, response.center = answer.volume_mm3, tool_pose(answer.center_pose)
        response.boundary_x_mm, response.boundary_y_mm, response.boundary_z_mm = answer.boundary_mm.T.tolist()
        response.limiting_constraint = list(answer.limiting_constraint)
        response.slice_area_mm2 = list(answer.slice_area_mm2)
        return response


def main(args=None) -> int:
    return runtime.run_node(KinematicsNode, args)


if __name__ == "__main__":
    main()
