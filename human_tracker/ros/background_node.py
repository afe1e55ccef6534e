"""``background_node``: background subtraction (§2.4.1) as a ROS 2 node.

Subscribes ``image``; publishes ``foreground`` (mono8, 255 on target pixels) and, only while
someone subscribes, ``background`` (mono8 dynamic reference frame). ``~/reset``
(std_srvs/Trigger) restarts the model from the next frame.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
from sensor_msgs.msg import Image
from std_srvs.srv import Trigger

from human_tracker.ros.common import RESULT_QOS, declare_working_width
from human_tracker.ros.image_conversion import array_to_image
from human_tracker.ros.run import spin_node
from human_tracker.ros.stage import ImageStage
from human_tracker.vision.cues.background import BackgroundModel, BackgroundParameters
from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.cues.stages import CueStages

__all__ = ['BackgroundNode', 'main']


class BackgroundNode(ImageStage):
    """Labels each pixel background or target and publishes the foreground mask."""

    def __init__(self, *, subscribe_image: bool = True, **kwargs: Any) -> None:
        super().__init__('background_node', subscribe_image=subscribe_image, **kwargs)
        parameters = self.bind_parameters(BackgroundParameters(), self._apply)
        self.working_width = declare_working_width(self)
        # Its stage alone; in a pipeline, the pipeline's stages (shared with the tracker's frame path).
        self.stages = CueStages(motion=BackgroundModel(parameters), motion_width=self.working_width)
        self.foreground_pub = self.create_publisher(Image, 'foreground', RESULT_QOS)
        self.background_pub = self.create_publisher(Image, 'background', RESULT_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.get_logger().info('configured: background subtraction')

    @property
    def model(self) -> BackgroundModel:
        """The background model of the stages this node publishes."""
        return self.stages.motion  # type: ignore[return-value]

    def warm_up(self) -> None:
        rng = np.random.default_rng(0)
        probe = BackgroundModel(self.model.parameters)
        for _ in range(2):
            probe.apply(rng.integers(0, 256, (32, 32), dtype=np.uint8))

    def _apply(self, parameters: BackgroundParameters) -> None:
        self.model.parameters = parameters

    def reset_state(self) -> None:
        self.model.reset()

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.model.reset()
        response.success = True
        response.message = 'background model reset: the next frame becomes the reference'
        self.get_logger().info(response.message)
        return response

    def handle_frame(self, image: np.ndarray, header: Any) -> None:
        """The foreground mask of one frame, published under ``header``."""
        self.publish_cue(self.stages.measure(self.frame(image, header)), header)

    def publish_cue(self, evidence: Evidence, header: Any) -> None:
        """Publish the frame's foreground mask (and the reference frame, while subscribed)."""
        self.counters.processed += 1
        self.foreground_pub.publish(array_to_image(evidence.motion, 'mono8', header))
        if self.background_pub.get_subscription_count() > 0:
            reference = self.model.reference_frame()
            if reference is not None:
                self.background_pub.publish(array_to_image(reference, 'mono8', header))

    def diagnostics_state(self) -> tuple[str, dict[str, Any]]:
        model = 'empty' if self.model.mean is None else 'learning'
        return 'OK', {'model': model, 'restarts_after_flooding': self.model.restarts}


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker background_node``; returns the exit code."""
    return spin_node(BackgroundNode, args, name='background_node', summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
