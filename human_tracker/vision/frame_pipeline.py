"""The one frame path: a camera frame in, every target's outcome out.

:class:`FramePipeline` is what the offline command (``track``), the ``pipeline`` node, the
tracker node fed by the cue nodes and ``make bench`` all run. Each frame goes through two
steps:

1. :meth:`FramePipeline.measure`: the cue stages (:class:`~human_tracker.vision.cues.stages.CueStages`:
   background subtraction §2.4.1 or optical flow §2.4.2, skin colour §3.2, the camera's shake)
   turn the frame into its :class:`~human_tracker.vision.cues.evidence.Evidence`. The skin classes
   adapt to the primary target's contour of the frame before, when adaptation is on.
2. :meth:`FramePipeline.track`: every target's tracker steps on that evidence
   (:meth:`~human_tracker.vision.people.persons.PersonTracker.step`), the primary target (the one a
   consumer of one target follows, :func:`~human_tracker.vision.track.outcomes.primary_target`) is
   chosen, and, where people have a head and hands, each person's gesture is read from them
   (:mod:`~human_tracker.vision.people.gestures`).

A tracker node fed by separate cue nodes receives the evidence's masks on topics and runs the
second step alone.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.cues.skin import SkinParameters, SkinSegmenter, default_skin_model
from human_tracker.vision.cues.stages import CueStages, Frame
from human_tracker.vision.filter.contour_filter import TrackerParameters
from human_tracker.vision.filter.templates import make_template
from human_tracker.vision.people.gestures import GestureReading, Gestures
from human_tracker.vision.people.persons import PersonTracker, kinds_of
from human_tracker.vision.track.outcomes import TrackedTarget, primary_target
from human_tracker.vision.track.parameters import TargetParameters
from human_tracker.vision.track.target import TargetTracker

__all__ = ['Frame', 'FramePipeline', 'FrameResult', 'build_people', 'warm_up']


@dataclass(frozen=True)
class FrameResult:
    """What one frame gave.

    Attributes:
        evidence: The frame's evidence (its cues).
        outcomes: One outcome per target that ran on the frame (the first person's always),
            in the slots' order.
        primary: The outcome a consumer of one target follows (pose, contour, status).
        grey: The frame had no colour: no skin could be found in it.
        gestures: Each person's gesture by person number (people with a head and hands only).
    """

    evidence: Evidence
    outcomes: list[TrackedTarget]
    primary: TrackedTarget
    grey: bool = False
    gestures: Mapping[int, GestureReading] = field(default_factory=dict)

    @property
    def motion_set_aside(self) -> bool:
        """The first target set the frame's motion mask aside (it covered most of the frame)."""
        return self.outcomes[0].result.motion_set_aside


class FramePipeline:
    """Every cue and every target's tracker of one camera stream, a frame at a time.

    Args:
        people: The targets' trackers (:func:`build_people`).
        stages: The cue stages this path computes itself; None: none (the masks come with the
            evidence, from other nodes).
    """

    def __init__(self, people: PersonTracker, stages: CueStages | None = None) -> None:
        self.people = people
        self.stages = stages or CueStages()
        self.kind = people.kinds[0]
        self.gestures = Gestures() if {'head', 'hand'} <= set(people.kinds) else None
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
        working width; ``people_options`` as :func:`build_people`."""
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
        gestures = {} if self.gestures is None else self.gestures.update(evidence.stamp_ns, outcomes)
        return FrameResult(evidence, outcomes, primary, self.stages.grey, gestures)

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
        if self.gestures is not None:
            self.gestures.reset()
        self._contour = None

    def warm_up(self) -> None:
        """Compile and run the trackers' kernels once, so that the first real frame is not late."""
        warm_up(self.people)


def build_people(
    target: str,
    filter_parameters: TrackerParameters,
    parameters: Mapping[str, TargetParameters] | None = None,
    *,
    hands: int = 1,
    max_people: int = 1,
    id_hold_frames: int = 15,
    template_file: str = '',
    num_points: int = 48,
) -> PersonTracker:
    """The trackers of ``target`` (``head``, ``hand`` or ``person``: a head and ``hands`` hands
    of up to ``max_people`` people), each kind with its ``parameters`` (its defaults where
    absent); ``template_file`` replaces the first kind's contour, ``num_points`` N of §2.3."""
    kinds = kinds_of(target, hands)
    templates = {kind: make_template(kind, num_points) for kind in kinds}
    templates[kinds[0]] = make_template(kinds[0], num_points, template_file)
    people = max_people if target == 'person' else 1
    return PersonTracker(kinds, filter_parameters, dict(parameters or {}), templates, people, id_hold_frames)


def warm_up(people: PersonTracker) -> None:
    """Run every compiled kernel the trackers of ``people`` use once, on a small random frame with
    their settings, and load the face detectors' model: the first real frame is then not late."""
    # Enough particles for a share of them to be drawn around a detection.
    filter_parameters = TrackerParameters(num_particles=10, min_scale=1.0)
    rng = np.random.default_rng(0)
    blank = np.zeros((32, 32), dtype=np.uint8)
    for tracker in people.trackers:
        if tracker.detector is not None:
            tracker.detector.load()
        probe = TargetTracker(tracker.template, filter_parameters, tracker.parameters)
        probe.initialise_from_box((8.0, 8.0, 16.0, 16.0))  # a box: the appearance kernels run too
        probe.process(rng.integers(0, 256, (32, 32, 3), dtype=np.uint8), blank, blank)
        # A detection (a face, a skin region) on a random frame is rare: its densities too.
        probe.filter.step(blank, detections=np.array([[16.0, 16.0, 16.0, 0.0]]))
