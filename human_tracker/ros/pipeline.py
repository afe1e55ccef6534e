"""``pipeline``: every stage in one process, frames handed over in memory.

A camera subscriber converts each image once and passes the array to the motion stage
(``motion_cue``: background subtraction, optical flow, or none), to the skin stage
(``skin_cue``: on for the hand by default) and then, with their masks, to the tracker. The
stages publish the same topics as the separate nodes, under the same parameters; only the
transport between them is gone.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from rclpy.node import Node

from human_tracker.ros.background_node import BackgroundNode
from human_tracker.ros.common import declare
from human_tracker.ros.optical_flow_node import OpticalFlowNode
from human_tracker.ros.skin_node import SkinNode
from human_tracker.ros.stage import ImageStage, run_nodes
from human_tracker.ros.tracker_node import TrackerNode
from human_tracker.vision.cues import camera_shake

__all__ = ['MOTION_CUES', 'CameraSubscriber', 'build_pipeline', 'main']

MOTION_CUES = {'none': None, 'background': BackgroundNode, 'flow': OpticalFlowNode}


class CameraSubscriber(ImageStage):
    """Subscribes the camera and runs the motion and skin stages, then the tracker, on each frame."""

    def __init__(
        self, motion_stage: ImageStage | None, skin_stage: SkinNode | None, tracker: TrackerNode, **kwargs: Any
    ) -> None:
        super().__init__('camera_subscriber', **kwargs)
        self.motion_stage = motion_stage
        self.skin_stage = skin_stage
        self.tracker = tracker

    def warm_up(self) -> None:
        """Every stage warms up before this subscriber (the pipeline's input) says it is ready."""
        for stage in (self.motion_stage, self.skin_stage, self.tracker):
            if stage is not None:
                stage.warm_up()

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        # The pipeline's input is managed for the pipeline: its tracker stops with it.
        self.tracker.say_nothing_tracked()
        return super().on_deactivate(state)

    def handle_frame(self, image: np.ndarray, header: Any, **cues: Any) -> object:
        mask = None if self.motion_stage is None else self.motion_stage.process_frame(image, header)
        skin = None if self.skin_stage is None else self.skin_stage.process_frame(image, header)
        self.counters.processed += 1
        # The background stage's measure of the camera's motion carries the particles (no cost).
        model = self.motion_stage.model if isinstance(self.motion_stage, BackgroundNode) else None
        shake = camera_shake(model, image.shape[1])
        return self.tracker.process_frame(image, header, motion=mask, skin=skin, camera_motion=shake)


def build_pipeline() -> list[Node]:
    """The pipeline's nodes: [selector, camera subscriber, motion and skin stages (if any), tracker]."""
    selector = Node('pipeline')
    cue = declare(
        selector,
        'motion_cue',
        'background',
        'Motion cue computed in process: none, background or flow.',
        read_only=True,
    )
    if cue not in MOTION_CUES:
        selector.destroy_node()
        raise ValueError(f'motion_cue must be one of {", ".join(MOTION_CUES)}, got {cue!r}')
    stage_type = MOTION_CUES[cue]
    motion_stage = None if stage_type is None else stage_type(subscribe_image=False)
    tracker = TrackerNode(subscribe_image=False)
    use_skin = declare(
        selector,
        'skin_cue',
        tracker.uses_skin,
        'Segment skin in process (§3.2); default: on when the tracker follows a hand (or a person).',
        read_only=True,
    )
    skin_stage = SkinNode(subscribe_image=False) if use_skin else None
    tracker.check_start(motion=stage_type is not None, skin=use_skin)
    camera = CameraSubscriber(motion_stage, skin_stage, tracker)
    stages = [stage for stage in (motion_stage, skin_stage) if stage is not None]
    return [selector, camera, *stages, tracker]


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker pipeline``; returns the exit code."""
    return run_nodes(build_pipeline, args, name='pipeline', summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
