"""``skin_node``: skin colour segmentation (§3.2) as a ROS 2 node.

Subscribes ``image`` (colour); publishes ``skin`` (mono8: 255 on the skin clusters, 128 on
skin split from a mixed cluster, 0 elsewhere: :func:`~human_tracker.vision.cues.skin.segment_skin`). With
``adaptation_rate`` > 0 it also subscribes the tracker's ``contour`` and adapts the skin
classes to the skin inside it, never further than ``max_drift`` from the learnt classes;
``~/reset`` (std_srvs/Trigger) forgets the adaptation.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from typing import Any

import numpy as np
from geometry_msgs.msg import PolygonStamped
from sensor_msgs.msg import Image
from std_srvs.srv import Trigger

from human_tracker.ros.common import RESULT_QOS, declare, declare_working_width
from human_tracker.ros.image_conversion import array_to_image
from human_tracker.ros.run import spin_node
from human_tracker.ros.stage import ImageStage
from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.cues.skin import (
    REGION_METHODS,
    SkinModel,
    SkinParameters,
    SkinSegmenter,
    default_skin_model,
)
from human_tracker.vision.cues.stages import CueStages

__all__ = ['SkinNode', 'main']


class SkinNode(ImageStage):
    """Labels skin pixels of each colour frame and publishes the label image."""

    def __init__(self, *, subscribe_image: bool = True, **kwargs: Any) -> None:
        super().__init__('skin_node', subscribe_image=subscribe_image, **kwargs)
        model_file = declare(
            self,
            'model_file',
            '',
            'Skin classes written by `human_tracker train-skin` (empty: the shipped model).',
            read_only=True,
        )
        model = SkinModel.load(model_file) if model_file else default_skin_model()
        self.model = model
        parameters = self.bind_parameters(SkinParameters(), self._apply)
        rate = declare(
            self,
            'adaptation_rate',
            0.0,
            'Weight of the tracked region when the skin classes adapt, per frame; 0: no adaptation.',
            low=0.0,
            high=1.0,
            read_only=True,
        )
        drift = declare(
            self,
            'max_drift',
            1.5,
            'Largest Mahalanobis distance an adapted class may move from the learnt one.',
            low=0.0,
            high=100.0,
            read_only=True,
        )
        self.working_width = declare_working_width(self)
        # Its stage alone; in a pipeline, the pipeline's stages (shared with the tracker's frame path).
        self.stages = CueStages(skin=SkinSegmenter(model, parameters, rate, drift), skin_width=self.working_width)
        self.grey_frames = 0
        self.last_frame_grey = False
        self.adaptations = 0
        self.contour: np.ndarray | None = None  # the tracker's latest contour, pixels
        self.skin_pub = self.create_publisher(Image, 'skin', RESULT_QOS)
        if rate > 0 and subscribe_image:
            # In a pipeline the frame path hands the contour over itself.
            self.create_subscription(PolygonStamped, 'contour', self._on_contour, RESULT_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.get_logger().info(
            f'configured: skin segmentation, {len(model.classes)} classes'
            + (f', adapting at {rate} from contour' if rate > 0 else '')
        )

    @property
    def segmenter(self) -> SkinSegmenter:
        """The skin segmenter of the stages this node publishes."""
        return self.stages.skin  # type: ignore[return-value]

    def warm_up(self) -> None:
        # Skin whose pixels alternate with a near colour: one region whose cluster is too spread
        # for a class, refused and split, so that every kernel of both phases compiles (a
        # random frame has no candidate cell: the first real frames waited for the rest).
        rng = np.random.default_rng(0)
        image = np.full((64, 64, 3), (60, 160, 60), dtype=np.uint8)
        image[8:56, 8:56] = np.array([(95, 135, 200), (110, 130, 150)], dtype=np.uint8)[rng.integers(0, 2, (48, 48))]
        for regions in REGION_METHODS:
            SkinSegmenter(self.model, replace(self.segmenter.parameters, regions=regions)).segment(image, 1.0)

    def _apply(self, parameters: SkinParameters) -> None:
        self.segmenter.parameters = parameters

    def reset_state(self) -> None:
        self.stages.reset()
        self.contour = None

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.reset_state()
        response.success = True
        response.message = 'skin classes back to the learnt ones'
        self.get_logger().info(response.message)
        return response

    def _on_contour(self, msg: PolygonStamped) -> None:
        points = np.array([[p.x, p.y] for p in msg.polygon.points], dtype=np.float64)
        if points.shape[0] >= 3 and np.isfinite(points).all():
            self.contour = points

    def handle_frame(self, image: np.ndarray, header: Any) -> None:
        """The skin labels of one frame, published under ``header``; the classes adapt to the
        latest contour (a frame or two old), which marks where the target is."""
        self.publish_cue(self.stages.measure(self.frame(image, header), self.contour), header)

    def publish_cue(self, evidence: Evidence, header: Any) -> None:
        """Publish the frame's skin labels: empty on a grey-level frame (no chromaticity), so that
        a tracker waiting for them is not held up."""
        self.last_frame_grey = self.stages.grey
        if self.last_frame_grey and self.grey_frames == 0:
            self.get_logger().warn('grey-level image: no skin can be found without colour')
        self.grey_frames += int(self.last_frame_grey)
        self.adaptations += int(self.stages.adapted)
        self.counters.processed += 1
        self.skin_pub.publish(array_to_image(evidence.skin, 'mono8', header))

    def diagnostics_state(self) -> tuple[str, dict[str, Any]]:
        return 'OK', {'frames_grey': self.grey_frames, 'adaptations': self.adaptations}

    def warnings(self) -> list[str]:
        grey = ['GREY_INPUT: the image has no colour: no skin can be found'] if self.last_frame_grey else []
        return super().warnings() + grey


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker skin_node``; returns the exit code."""
    return spin_node(SkinNode, args, name='skin_node', summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
