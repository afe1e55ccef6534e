"""The one frame path: a camera frame in, every target's outcome out.

:class:`FramePipeline` is what the offline command (``track``), the ``pipeline`` node, the
tracker node fed by the cue nodes and ``make bench`` all run. Each frame goes through two
steps:

1. :meth:`FramePipeline.measure`: the cue stages (:class:`~human_tracker.vision.cues.CueStages`:
   background subtraction §2.4.1 or optical flow §2.4.2, skin colour §3.2, the camera's shake)
   turn the frame into its :class:`~human_tracker.vision.evidence.Evidence`. The skin classes
   adapt to the primary target's contour of the frame before, when adaptation is on.
2. :meth:`FramePipeline.track`: every target's tracker steps on that evidence
   (:meth:`~human_tracker.vision.people.PersonTracker.step`), and the primary target (the one a
   consumer of one target follows, :func:`~human_tracker.vision.outcomes.primary_target`) is
   chosen.

A tracker node fed by separate cue nodes receives the evidence's masks on topics and runs the
second step alone.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from human_tracker.vision.cues import CueStages, Frame, build_people, warm_up
from human_tracker.vision.evidence import Evidence
from human_tracker.vision.outcomes import TrackedTarget, primary_target
from human_tracker.vision.people import PersonTracker
from human_tracker.vision.skin import SkinParameters, SkinSegmenter, default_skin_model
from human_tracker.vision.target_parameters import TargetParameters
from human_tracker.vision.tracker import TrackerParameters

__all__ = ['Frame', 'FramePipeline', 'FrameResult']


@dataclass(frozen=True)
class FrameResult:
    """What one frame gave.

    Attributes:
        evidence: The frame's evidence (its cues).
        outcomes: One outcome per target that ran on the frame (the first person's always),
            in the slots' order.
        primary: The outcome a consumer of one target follows (pose, contour, status).
        grey: The frame had no colour: no skin could be found in it.
    """

    evidence: Evidence
    outcomes: list[TrackedTarget]
    primary: TrackedTarget
    grey: bool = False

    @property
    def motion_set_aside(self) -> bool:
        """The first target set the frame's motion mask aside (it covered most of the frame)."""
        return self.outcomes[0].result.motion_set_aside


class FramePipeline:
    """Every cue and every target's tracker of one camera stream, a frame at a time.

    Args:
        people: The targets' trackers (:func:`~human_tracker.vision.cues.build_people`).
        stages: The cue stages this path computes itself; None: none (the masks come with the
            evidence, from other nodes).
    """

    def __init__(self, people: PersonTracker, stages: CueStages | None = None) -> None:
        self.people = people
        self.stages = stages or CueStages()
        self.kind = people.kinds[0]
        self._contour: np.ndarray | None = None  # the primary target's, for the skin's adaptation

    @classmethod
    def for_target(
        cls,
        target: str,
        filter_parameters: TrackerParameters | None = None,
        parameters: Mapping[str, TargetParameters] | None = None,
        *,
        cue: str = 'background',
        skin: bool | None = None,
        skin_parameters: SkinParameters | None = None,
        **people_options: object,
    ) -> FramePipeline:
        """The path of ``target`` (``head``, ``hand`` or ``person``) with the motion ``cue`` and,
        when ``skin`` (None: when a hand is followed), skin labels, the cues at the first target's
        working width; ``people_options`` as :func:`~human_tracker.vision.cues.build_people`."""
        people = build_people(target, filter_parameters or TrackerParameters(), parameters, **people_options)
        use_skin = people.uses_skin if skin is None else skin
        segmenter = SkinSegmenter(default_skin_model(), skin_parameters or SkinParameters()) if use_skin else None
        return cls(people, CueStages.build(cue, segmenter, people.trackers[0].parameters.working_width))

    def measure(self, frame: Frame) -> Evidence:
        """Step 1: the frame's evidence from the cue stages."""
        return self.stages.measure(frame, self._contour if self.stages.adapts_skin else None)

    def track(self, evidence: Evidence, primary_id: int = 0) -> FrameResult:
        """Step 2: every target's tracker on ``evidence``; the primary target is the head (or the
        first kind) holding ``primary_id`` while it is followed, else the followed one nearest
        the image's centre."""
        outcomes = self.people.step(evidence)
        height, width = evidence.image.shape[:2]
        primary = primary_target(outcomes, self.kind, (width / 2.0, height / 2.0), primary_id)
        self._contour = primary.result.estimate.contour if primary.result.tracking else None
        return FrameResult(evidence, outcomes, primary, self.stages.grey)

    def process(self, frame: Frame, primary_id: int = 0) -> FrameResult:
        """Both steps on one frame."""
        return self.track(self.measure(frame), primary_id)

    def start_from_box(self, box: tuple[float, float, float, float], kind: str | None = None) -> None:
        """Start the first person's ``kind`` (the first kind when None) on ``box`` (x, y, w, h,
        camera pixels) from the next frame."""
        self.people.initialise_from_box(box, kind)

    def reset(self) -> None:
        """Forget every target and what the cue stages learnt (a new sequence)."""
        self.people.reset()
        self.stages.reset()
        self._contour = None

    def warm_up(self) -> None:
        """Compile and run the trackers' kernels once, so that the first real frame is not late."""
        warm_up(self.people)
