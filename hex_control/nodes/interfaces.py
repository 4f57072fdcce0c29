"""What the nodes agree on: the QoS of the shared topics and the Contour conversion.

- ``LATCHED``: configuration-like state whose latest value a late joiner needs (a pass
  command, a force trajectory, the contour): reliable, transient-local, depth 1.
- ``RESULTS``: pass results, kept by their publisher (depth 10) so that one sent while
  the sequence planner restarts still arrives; receivers ignore results they have seen.
- Streams (measurements, commands, setpoints) use reliable, volatile, depth 100.
"""

from __future__ import annotations

import numpy as np
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from hex_control.grinding.contour import Contour
from hex_control_msgs.msg import Contour as ContourMsg

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
RESULTS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
STREAM = 100


def contour_from_message(msg: ContourMsg) -> Contour:
    parent = list(msg.parent_mm) or None
    return Contour(np.asarray(msg.x_mm, float), np.asarray(msg.z_mm, float),
                   None if parent is None else np.asarray(parent, float))


def contour_to_message(contour: Contour, job_id: str, pass_index: int, width_mm: float) -> ContourMsg:
    return ContourMsg(job_id=job_id, pass_index=pass_index, bead_width_mm=float(width_mm),
                      x_mm=contour.x_mm.tolist(), z_mm=contour.z_mm.tolist(), parent_mm=contour.parent_mm.tolist())
