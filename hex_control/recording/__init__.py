"""Recording the graph's messages in rosbag2's MCAP layout (no ROS)."""
