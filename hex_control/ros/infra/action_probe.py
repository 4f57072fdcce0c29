"""Know that an action server's answers reach this client before sending it a goal.

A Fast DDS service drops a response when the client's response reader has not matched
within 100 ms (ros2/rmw_fastrtps#390, #467). ``wait_for_server`` cannot see that — it
shows only this side of discovery — and a lost goal response leaves the client waiting
for an acceptance that never comes. On a loaded machine discovery can take seconds.

``ResponseProbe(client)`` is a wait condition: each call it checks whether the server has
answered a probe, and sends a new probe every ``interval_s``. The probe is a cancel request
for a goal id nobody uses, which the action protocol answers with "unknown goal" and no
side effect. Once one answer arrived, the goal's answer will too (both services' readers
were announced together when the client was made).
"""

from __future__ import annotations

import time
import uuid

from rclpy.action.client import ClientGoalHandle
from unique_identifier_msgs.msg import UUID


class ResponseProbe:
    """Wait condition: truthy once the server behind ``client`` (an ActionClient) has answered."""

    def __init__(self, client, interval_s: float = 1.0):
        self.client, self.interval_s = client, float(interval_s)
        self._answers, self._sent_at = [], -float("inf")
        self.server_seen = False  # whether wait_for_server would have returned

    def __str__(self) -> str:
        """Where the wait stands, for a timeout's message: seen, probes sent and answered."""
        answered = sum(answer.done() for answer in self._answers)
        return (f"server {'seen' if self.server_seen else 'never seen'} in the graph, "
                f"{len(self._answers)} probe(s) sent, {answered} answered")

    def __call__(self) -> bool:
        if any(answer.done() for answer in self._answers):
            return True
        self.server_seen = self.server_seen or self.client.server_is_ready()
        if self.server_seen and time.monotonic() - self._sent_at >= self.interval_s:
            nobody = UUID(uuid=list(uuid.uuid4().bytes))
            response = self.client._action_type.Impl.SendGoalService.Response(accepted=True)
            self._answers.append(ClientGoalHandle(self.client, nobody, response).cancel_goal_async())
            self._sent_at = time.monotonic()
        return False
