"""hex_control: hierarchical control of weld-bead grinding on a parallel-kinematic machine tool.

Unit convention (stated once, used everywhere in the library and in hex_control_msgs):
lengths in mm, forces in N, time in s, angles in rad, power in W, energy in J.
Names carry the unit as a suffix (``feed_speed_mm_s``) or the docstring states it.
Standard ROS messages (geometry_msgs, sensor_msgs) keep their REP 103 SI meaning;
the nodes convert at that boundary.

The domain packages (everything except ``hex_control.ros`` and the topic tools of
``hex_control.cli``) are plain numpy/scipy code without rclpy.
"""

__version__ = "0.1.0"
