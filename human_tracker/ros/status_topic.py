"""The tracker node's latched ``status`` topic: the primary target's state and its cues' support."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.node import Node
from std_msgs.msg import Header

from human_tracker.ros.common import LATCHED_QOS, node_status
from human_tracker.ros.tracker_outputs import estimate_values
from human_tracker.vision.track.lifecycle import LOST
from human_tracker.vision.track.target import TargetResult

__all__ = ['PrimaryState', 'StatusTopic']


class PrimaryState(NamedTuple):
    """What ``status`` says: the primary target's state word and last result, the node's
    warnings, and whether the last frame had no colour."""

    status: str
    result: TargetResult | None
    warnings: list[str]
    grey: bool


class StatusTopic:
    """The node's latched ``status``: the primary target's state and its cues' support, stamped
    with the last frame tracked; sent at once when the state or the shape changes (a hand opening
    or closing is a gesture), where a head faces changes, or the frames lose their colour, and every
    ``status_period``."""

    def __init__(self, node: Node, state: Callable[[], PrimaryState]) -> None:
        """A publisher on ``node``, named after it; ``state`` says the primary target's state now."""
        self.node = node
        self.state = state
        self.pub = node.create_publisher(DiagnosticArray, 'status', LATCHED_QOS)
        self.header = Header()
        self.sent: tuple[str, str, str, bool] | None = None

    def on_frame(self, header: Any) -> None:
        """A frame was tracked under ``header``: publish if what a consumer waits for changed."""
        self.header = header
        if self._key(self.state()) != self.sent:
            self.publish()

    def publish(self) -> None:
        """Publish the state now."""
        state = self.state()
        values = estimate_values(state.result)
        if state.warnings:
            values['warnings'] = '; '.join(state.warnings)
        level = DiagnosticStatus.WARN if state.status == LOST or state.warnings else DiagnosticStatus.OK
        status = node_status(self.node, state.status, values, level=level)
        self.pub.publish(DiagnosticArray(header=self.header, status=[status]))
        self.sent = self._key(state)

    @staticmethod
    def _key(state: PrimaryState) -> tuple[str, str, str, bool]:
        result = state.result
        estimate = None if result is None else result.estimate
        shape = '' if estimate is None else estimate.shape
        facing = '' if result is None or result.facing is None else str(result.facing)
        return state.status, shape, facing, state.grey
