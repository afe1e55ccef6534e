"""``pipeline``: every stage in one process, frames handed over in memory.

A camera subscriber converts each image once and runs the frame path the offline command runs
(:class:`~human_tracker.vision.frame_pipeline.FramePipeline`): the cue stages measure the
frame (``motion_cue``: background subtraction, optical flow, or none; ``skin_cue``: on for
the hand by default), then the tracker steps on that evidence. The stage nodes publish their
cue on the same topics as the separate nodes, under the same parameters; only the transport
between them is gone.
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
from human_tracker.ros.run import run_nodes
from human_tracker.ros.skin_node import SkinNode
from human_tracker.ros.stage import ImageStage
from human_tracker.ros.tracker_node import TrackerNode
from human_tracker.vision.cues.stages import CueStages

__all__ = ['MOTION_CUES', 'CameraSubscriber', 'build_pipeline', 'main']

MOTION_CUES = {'none': None, 'background': BackgroundNode, 'flow': OpticalFlowNode}
CueNode = BackgroundNode | OpticalFlowNode


class CameraSubscriber(ImageStage):
    """Subscribes the camera and runs the tracker's frame path on each frame: the cue stages of
    the motion and skin nodes, whose cues those nodes publish, then the tracker."""

    def __init__(
        self, motion_stage: CueNode | None, skin_stage: SkinNode | None, tracker: TrackerNode, **kwargs: Any
    ) -> None:
        super().__init__('camera_subscriber', **kwargs)
        self.motion_stage = motion_stage
        self.skin_stage = skin_stage
        self.tracker = tracker
        self.cue_nodes = [stage for stage in (motion_stage, skin_stage) if stage is not None]
        # One set of stages for the frame path and the nodes that publish (and reset) them.
        stages = CueStages(
            motion=None if motion_stage is None else motion_stage.stages.motion,
            skin=None if skin_stage is None else skin_stage.stages.skin,
            motion_width=320 if motion_stage is None else motion_stage.working_width,
            skin_width=320 if skin_stage is None else skin_stage.working_width,
        )
        for node in self.cue_nodes:
            node.stages = stages
        if not tracker.describing:
            tracker.frame_pipeline.stages = stages

    def warm_up(self) -> None:
        """Every stage warms up before this subscriber (the pipeline's input) says it is ready."""
        for stage in (*self.cue_nodes, self.tracker):
            stage.warm_up()

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        # The pipeline's input is managed for the pipeline: its tracker stops with it.
        self.tracker.say_nothing_tracked()
        return super().on_deactivate(state)

    def reset_state(self) -> None:
        """Time went backwards: the cue stages start over (the tracker resets its targets itself)."""
        self.tracker.frame_pipeline.stages.reset()

    def on_wire_image(self, typename: str, data: bytes) -> None:
        """Read and process one frame, then tell the stages after this one how many frames never
        reached them (:meth:`_count_what_never_arrived`)."""
        super().on_wire_image(typename, data)
        self._count_what_never_arrived()

    def _count_what_never_arrived(self) -> None:
        """Each stage's ``frames_dropped``: the frames the camera sent that never reached it,
        whatever the cause: dropped before this subscriber, or received here and not passed on
        (rejected, a duplicate, inactive), so that its received + dropped is what was sent."""
        never = self.counters.dropped + self.counters.received - self.counters.processed
        for node in (*self.cue_nodes, self.tracker):
            node.counters.dropped = never

    def handle_frame(self, image: np.ndarray, header: Any) -> object:
        # The flow stage's frame carries camera_info's K and the camera's angular velocity.
        frame = (self.motion_stage or self).frame(image, header)
        evidence = self.tracker.frame_pipeline.measure(frame)
        for node in self.cue_nodes:
            node.counters.received += 1
            node.publish_cue(evidence, header)
        self.counters.processed += 1
        return self.tracker.process_frame(image, header, evidence=evidence)


def build_pipeline(**node_options: Any) -> list[Node]:
    """The pipeline's nodes: [selector, camera subscriber, motion and skin stages (if any),
    tracker]; ``node_options`` go to every node (a ``context``)."""
    selector = Node('pipeline', **node_options)
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
    motion_stage = None if stage_type is None else stage_type(subscribe_image=False, **node_options)
    tracker = TrackerNode(subscribe_image=False, **node_options)
    use_skin = declare(
        selector,
        'skin_cue',
        tracker.uses_skin,
        'Segment skin in process (§3.2); default: on when the tracker follows a hand (or a person).',
        read_only=True,
    )
    skin_stage = SkinNode(subscribe_image=False, **node_options) if use_skin else None
    tracker.check_start(motion=stage_type is not None, skin=use_skin)
    camera = CameraSubscriber(motion_stage, skin_stage, tracker, **node_options)
    stages = [stage for stage in (motion_stage, skin_stage) if stage is not None]
    return [selector, camera, *stages, tracker]


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker pipeline``; returns the exit code."""
    return run_nodes(build_pipeline, args, name='pipeline', summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
