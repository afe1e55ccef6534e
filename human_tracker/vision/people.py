"""Following a person's head and hand together, each target under a stable id.

The paper's introduction asks for "the determination of the person's pose as well as the
location of the hand(s)". A person here is a head (head-and-shoulders contour) and a hand
(open-hand contour), each its own :class:`~human_tracker.vision.target.TargetTracker` over the
same frames and cues. The two share what they know of the face: the head's tracker finds the
face (its proposals), and the hand's tracker, which must keep off the face (a face is skin of
about a hand's size), is handed where the head's contour puts the face while a face has
just been found on the head, instead of running its own detector (which looks when the head
has no fresh face: :meth:`PersonTracker._face_of`).

Ids: every time a target is taken up (its filter starts TRACKING after WAITING or LOST, or
restarts farther than the target's width from where it was: onto another face, another
person) it gets a new id, never reused while the tracker lives; a target LOST keeps no id. A
consumer that sees the same id on two frames sees the same followed target.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from human_tracker.vision.faces import FACE_ON_HEAD
from human_tracker.vision.target import TRACKING, TargetParameters, TargetResult, TargetTracker, parameters_for
from human_tracker.vision.templates import ContourTemplate, make_template
from human_tracker.vision.tracker import TrackerParameters

__all__ = ['KINDS', 'TARGETS', 'PersonTracker', 'TrackedTarget', 'kinds_of', 'targets_line']

KINDS = ('head', 'hand')
TARGETS = (*KINDS, 'person')
"""What a tracker follows: one head, one hand, or a person (a head and a hand)."""

# A head's contour tells the hand where the face is only while its face was found on it within
# this many frames: a head that slid onto the raised arm (hand2) would send the hand to the face.
FRESH_FACE_FRAMES = 4


def kinds_of(target: str) -> tuple[str, ...]:
    """The kinds of target a ``target`` (``head``, ``hand`` or ``person``) follows."""
    if target not in TARGETS:
        raise ValueError(f'target must be one of {", ".join(TARGETS)}, got {target!r}')
    return KINDS if target == 'person' else (target,)


class TrackedTarget(NamedTuple):
    """One target's outcome on a frame.

    Attributes:
        id: The target's id while it is followed (from 1, never reused); 0 while it is not
            (WAITING or LOST).
        kind: ``head`` or ``hand``.
        person: The person the target belongs to (1: one person is followed).
        result: The target tracker's outcome, in the camera's pixels.
    """

    id: int
    kind: str
    person: int
    result: TargetResult


def targets_line(outcomes: Sequence[TrackedTarget]) -> str:
    """Every target's kind, id (- while it has none) and state: ``head 1 TRACKING, hand - LOST``."""
    return ', '.join(f'{o.kind} {o.id or "-"} {o.result.status}' for o in outcomes)


@dataclass
class PersonTracker:
    """One :class:`TargetTracker` per kind of ``kinds`` over the same frames, with ids.

    Args:
        kinds: The targets followed: ``('head',)``, ``('hand',)`` or ``('head', 'hand')``
            (:func:`kinds_of`).
        filter_parameters: The particle filters' constants (each target's own generator is
            seeded from ``seed`` + its place in ``kinds``, so a run is reproducible).
        parameters: Each kind's cue and loss constants (:func:`parameters_for` where absent).
        templates: Each kind's contour (the built-in one where absent).
    """

    kinds: tuple[str, ...] = ('head',)
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    parameters: dict[str, TargetParameters] = field(default_factory=dict)
    templates: dict[str, ContourTemplate] = field(default_factory=dict)
    trackers: dict[str, TargetTracker] = field(init=False)
    ids: dict[str, int] = field(init=False)
    last_id: int = field(default=0, init=False)
    last_states: dict[str, np.ndarray] = field(init=False)

    def __post_init__(self) -> None:
        if not self.kinds or len(set(self.kinds)) != len(self.kinds) or not set(self.kinds) <= set(KINDS):
            raise ValueError(f'kinds must be distinct kinds among {", ".join(KINDS)}, got {self.kinds}')
        self.trackers = {}
        for place, kind in enumerate(self.kinds):
            seed = self.filter_parameters.seed + place
            self.trackers[kind] = TargetTracker(
                self.templates.get(kind) or make_template(kind),
                replace(self.filter_parameters, seed=seed),
                self.parameters.get(kind) or parameters_for(kind),
            )
        self.ids = dict.fromkeys(self.kinds, 0)
        self.last_states = {}

    @property
    def uses_skin(self) -> bool:
        """Whether a target's tracker wants skin labels (a hand's)."""
        return 'hand' in self.kinds

    def initialise_from_box(self, box: tuple[float, float, float, float], kind: str | None = None) -> None:
        """Start ``kind``'s target (the first of ``kinds`` when None) on a box (x, y, w, h),
        camera pixels; the others start by themselves."""
        self.trackers[kind or self.kinds[0]].initialise_from_box(box)

    def reset(self) -> None:
        """Forget every target; the ids already given stay retired."""
        for kind, tracker in self.trackers.items():
            tracker.reset()
            self.ids[kind] = 0
        self.last_states.clear()

    def process(
        self, image: np.ndarray, motion: np.ndarray | None = None, skin: np.ndarray | None = None
    ) -> list[TrackedTarget]:
        """Track every target on one frame (arguments as :meth:`TargetTracker.process`; beside a
        hand, the skin labels go to the hand only: a head-and-shoulders outline is not skin).

        Returns:
            One outcome per kind, in the order of ``kinds``.
        """
        outcomes = []
        face = None
        for kind in self.kinds:
            tracker = self.trackers[kind]
            was_tracking = tracker.status == TRACKING
            if kind == 'head':
                result = tracker.process(image, motion, skin if len(self.kinds) == 1 else None)
                face = self._face_of(tracker, result)
            else:
                result = tracker.process(image, motion, skin, face=face)
            if result.tracking and (not was_tracking or self.ids[kind] == 0 or self._jumped(kind, result)):
                self.last_id += 1
                self.ids[kind] = self.last_id
            elif not result.tracking:
                self.ids[kind] = 0
            if result.estimate is not None:
                self.last_states[kind] = result.estimate.state
            outcomes.append(TrackedTarget(self.ids[kind], kind, 1, result))
        return outcomes

    def _jumped(self, kind: str, result: TargetResult) -> bool:
        """Whether the filter restarted farther than the target's width (its scale) from its
        last estimate."""
        last = self.last_states.get(kind)
        if not result.initialised or last is None or result.estimate is None:
            return False
        return float(np.hypot(*(result.estimate.state[:2] - last[:2]))) > last[2]

    @staticmethod
    def _face_of(head: TargetTracker, result: TargetResult) -> tuple[float, float, float, float] | None:
        """Where the person's face is (x, y, w, h, camera pixels): where the head's contour puts it
        while a face has just been found on it, else None (a head that slid onto the raised arm
        would send the hand to the face): the hand's own detector looks then."""
        fresh = head.last_face is not None and head.frames_without_own_face <= FRESH_FACE_FRAMES
        return FACE_ON_HEAD.box(result.estimate.state) if result.tracking and fresh else None
