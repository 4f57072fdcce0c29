"""Thin rclpy adapters around the hex_control library: one module per node.

A node converts messages to library types, calls the library and converts back; it
holds parameters, timers and diagnostics, and no algorithm.
"""

import os

# A node shares the machine's cores with the rest of the graph. OpenBLAS's worker threads
# then wait for cores the other nodes hold, and the planners' small matrix products get
# slower, not faster: the demo job's SDP solve took 1.8-4.6 s with the default threads and
# 0.4-1.0 s with one, measured beside a running demo. Set before numpy loads; an explicit
# setting in the environment wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
