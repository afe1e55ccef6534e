"""``optical_flow_node``: dense optical flow and the motion mask (§2.4.2) as a ROS 2 node.

Subscribes ``image``, ``camera_info`` (optional) and ``angular_velocity`` (optional,
geometry_msgs/Vector3Stamped: the camera's angular velocity in rad/s, expressed in its
optical frame, e.g. from a pan-tilt unit's joint rates); publishes ``motion`` (mono8, 255
where the flow is non-zero after noise filtering) and, only while someone subscribes,
``flow`` (32FC2, pixels per frame). With an angular velocity, the flow a pure rotation
induces is compensated before the mask is made.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import Image

from human_tracker.ros.common import RESULT_QOS, declare, declare_working_width
from human_tracker.ros.image_conversion import array_to_image
from human_tracker.ros.run import spin_node
from human_tracker.ros.stage import ImageStage, stamp_ns
from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.cues.optical_flow import FlowParameters, OpticalFlow
from human_tracker.vision.cues.stages import CueStages, Frame

__all__ = ['OpticalFlowNode', 'main']


class OpticalFlowNode(ImageStage):
    """Computes the flow between consecutive frames and publishes the motion mask."""

    def __init__(self, *, subscribe_image: bool = True, **kwargs: Any) -> None:
        super().__init__('optical_flow_node', subscribe_image=subscribe_image, **kwargs)
        parameters = self.bind_parameters(FlowParameters(), self._apply)
        self.working_width = declare_working_width(self)
        # Its stage alone; in a pipeline, the pipeline's stages (shared with the tracker's frame path).
        self.stages = CueStages(motion=OpticalFlow(parameters), motion_width=self.working_width)
        self.max_rotation_age = declare(
            self,
            'angular_velocity_timeout',
            0.5,
            'Seconds after which an angular velocity is too old to use.',
            low=0.0,
            high=60.0,
        )
        self.angular_velocity: tuple[int, np.ndarray] | None = None
        self.motion_pub = self.create_publisher(Image, 'motion', RESULT_QOS)
        self.flow_pub = self.create_publisher(Image, 'flow', RESULT_QOS)
        self.use_camera_info()
        self.create_subscription(Vector3Stamped, 'angular_velocity', self._on_angular_velocity, RESULT_QOS)
        self.get_logger().info(f'configured: optical flow ({parameters.method})')

    @property
    def flow(self) -> OpticalFlow:
        """The optical flow of the stages this node publishes."""
        return self.stages.motion  # type: ignore[return-value]

    def warm_up(self) -> None:
        rng = np.random.default_rng(0)
        probe = OpticalFlow(self.flow.parameters)
        for _ in range(2):
            probe.apply(rng.integers(0, 256, (32, 32), dtype=np.uint8))

    def _apply(self, parameters: FlowParameters) -> None:
        self.stages.motion = OpticalFlow(parameters, previous=self.flow.previous)

    def reset_state(self) -> None:
        self.stages.reset()

    def _on_angular_velocity(self, msg: Vector3Stamped) -> None:
        self.angular_velocity = (stamp_ns(msg.header), np.array([msg.vector.x, msg.vector.y, msg.vector.z]))

    def frame(self, image: np.ndarray, header: Any) -> Frame:
        """The frame with camera_info's K and the camera's angular velocity, while it is recent."""
        stamp = stamp_ns(header)
        omega = None
        if self.angular_velocity is not None and abs(stamp - self.angular_velocity[0]) <= self.max_rotation_age * 1e9:
            omega = self.angular_velocity[1]
        return Frame(image, stamp, self.camera.intrinsics(image.shape[1], image.shape[0]), omega)

    def handle_frame(self, image: np.ndarray, header: Any) -> None:
        """The motion mask of one frame, published under ``header``."""
        self.publish_cue(self.stages.measure(self.frame(image, header)), header)

    def publish_cue(self, evidence: Evidence, header: Any) -> None:
        """Publish the frame's motion mask (and the flow, while subscribed)."""
        self.counters.processed += 1
        self.motion_pub.publish(array_to_image(evidence.motion, 'mono8', header))
        if self.flow_pub.get_subscription_count() > 0 and self.stages.flow is not None:
            self.flow_pub.publish(array_to_image(self.stages.flow, '32FC2', header))

    def diagnostics_state(self) -> tuple[str, dict[str, Any]]:
        return 'OK', {'method': self.flow.parameters.method, 'rotation_compensation': self.angular_velocity is not None}


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker optical_flow_node``; returns the exit code."""
    return spin_node(OpticalFlowNode, args, name='optical_flow_node', summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
