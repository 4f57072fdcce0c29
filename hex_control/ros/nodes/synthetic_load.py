"""Node ``synthetic_load``: publishes a simulated Gauss-Markov load (eqs 6.1-6.3).

Stands in for a load measurement when there is no plant: y(t) = L_bar + dL(t) + v(t) at
``rate_hz``, as ``std_msgs/Float64`` or as ``geometry_msgs/WrenchStamped`` (force.z, N), with a
history of ``qos_depth`` samples.
Seeded, so a run is reproducible; stops after ``count`` samples if ``count`` > 0. In a
process that also listens to the answers, ``may_publish(sent)`` can hold the next sample back
(flow control), so that no history overflows when the consumer falls behind, and
``republish_last()`` sends the last sample again, stamp and all (a start handshake: a reader
that matches the writer late drops what came before).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from std_msgs.msg import Float64

from hex_control.estimation import GaussMarkovModel
from hex_control.ros.infra.parameters import ParameterSpec as Spec
from hex_control.ros.infra.parameters import declare_parameters
from hex_control.ros.infra.runtime import run_node

_TYPES = {"std_msgs/msg/Float64": Float64, "geometry_msgs/msg/WrenchStamped": WrenchStamped}

PARAMETERS = {
    "topic": Spec("load", "topic of the published load"),
    "type": Spec("std_msgs/msg/Float64", "message type of topic", choices=tuple(_TYPES)),
    "a": Spec(0.9, "Gauss-Markov coefficient a (eq. 6.2)", -0.9999, 0.9999),
    "process_variance": Spec(1.0, "W, variance of w(t) (load unit^2)", 0.0, 1e12),
    "measurement_variance": Spec(1.0, "V, variance of v(t) (load unit^2)", 0.0, 1e12),
    "mean": Spec(0.0, "mean load L_bar (load unit)", -1e12, 1e12),
    "rate_hz": Spec(100.0, "publishing rate", 0.01, 10_000.0),
    "seed": Spec(0, "seed of the series", 0, 2**31 - 1),
    "count": Spec(0, "samples to publish; 0 = a million, then the series repeats", 0, 1_000_000),
    "qos_depth": Spec(10, "history depth of the publisher (samples)", 1, 10_000),
}


class SyntheticLoadNode(Node):
    def __init__(self, may_publish: Callable[[int], bool] | None = None, **kwargs):
        super().__init__("synthetic_load", **kwargs)
        self._may_publish = may_publish
        declare_parameters(self, PARAMETERS)
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        model = GaussMarkovModel(p("a"), p("process_variance"), p("measurement_variance"))
        total = p("count") if p("count") > 0 else 1_000_000
        _, measurements = model.simulate(total, np.random.default_rng(p("seed")))
        self.measurements = p("mean") + measurements
        self._count = p("count")
        self._sent = 0
        self._last = None  # the last message sent
        self._class = _TYPES[p("type")]
        self._publisher = self.create_publisher(self._class, p("topic"), p("qos_depth"))
        self._timer = self.create_timer(1.0 / p("rate_hz"), self._publish)

    def _publish(self) -> None:
        if self._count and self._sent >= self._count:
            self._timer.cancel()
            return
        if self._sent == 0 and self._publisher.get_subscription_count() == 0:
            return  # nobody listens yet: do not start the series into the void
        if self._may_publish is not None and not self._may_publish(self._sent):
            return
        value = float(self.measurements[self._sent % self.measurements.size])
        msg = self._class()
        if self._class is Float64:
            msg.data = value
        else:
            msg.header.stamp = self.get_clock().now().to_msg()
            msg.header.frame_id = "tool"
            msg.wrench.force.z = value
        self._publisher.publish(msg)
        self._last = msg
        self._sent += 1

    def republish_last(self) -> None:
        if self._last is not None:
            self._publisher.publish(self._last)


def main(args=None) -> int:
    return run_node(SyntheticLoadNode, args)


if __name__ == "__main__":
    main()
