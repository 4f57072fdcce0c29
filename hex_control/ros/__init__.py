"""The ROS 2 side of hex_control (the only place that imports rclpy or message types;
DESIGN.md section 2), by role:

- :mod:`.nodes`: one module per node: parameters -> settings -> the library's core;
  messages in and out; spin.
- :mod:`.infra`: what every node uses: runtime, parameters, diagnostics, QoS profiles,
  message conversion, message info (lost messages, command ownership).
- :mod:`.app`: the applications: the job session and graph runner (``hexctl demo``), a
  campaign's cell, the load predictor demo.
- :mod:`.tools`: the ros2cli stand-ins (``hexctl topic|node|param|...``) and the recorder.
"""

import os

# A node shares the machine's cores with the rest of the graph. OpenBLAS's worker threads
# then wait for cores the other nodes hold, and the planners' small matrix products get
# slower, not faster: the demo job's SDP solve took 1.8-4.6 s with the default threads and
# 0.4-1.0 s with one, measured beside a running demo. Set before numpy loads; an explicit
# setting in the environment wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
