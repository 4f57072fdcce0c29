"""The ros2cli and rosbag2 stand-ins: ``hexctl topic|node|param|service|action|interface``
and the recorder behind ``hexctl record`` and the demo's recording."""
