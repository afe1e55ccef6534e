"""What tracking reports on a frame: each target's outcome, and the target a consumer of one follows."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from human_tracker.vision.faces.facing import Facing
from human_tracker.vision.filter.contour_filter import TrackEstimate
from human_tracker.vision.geometry.boxes import box_centre
from human_tracker.vision.track.lifecycle import TRACKING, TrackState

__all__ = ['TargetResult', 'TrackedTarget', 'primary_target', 'state_words', 'targets_line']


@dataclass
class TargetResult:
    """One frame's outcome.

    Attributes:
        status: WAITING (never had a target), TRACKING, or LOST.
        estimate: The filter's estimate (camera pixels), None while WAITING.
        initialised: Whether the filter was (re)initialised on this frame.
        motion_set_aside: Whether the frame's motion mask covered more than
            ``max_motion_fraction`` of it and was not used.
        detections: The detector's boxes (x, y, w, h, camera pixels) on this frame.
        facing: Where a head faces (:mod:`~human_tracker.vision.faces.facing`); None for a target
            without a face detector (a hand).
    """

    status: TrackState
    estimate: TrackEstimate | None
    initialised: bool = False
    motion_set_aside: bool = False
    detections: tuple[tuple[float, float, float, float], ...] = ()
    facing: Facing | None = None

    @property
    def tracking(self) -> bool:
        """Whether a pose should be published for this frame."""
        return self.status == TRACKING and self.estimate is not None


class TrackedTarget(NamedTuple):
    """One target's outcome on a frame.

    Attributes:
        id: The target's id while it is followed (from 1, never reused); 0 while it is not
            (WAITING or LOST).
        kind: ``head`` or ``hand``.
        person: The person the target belongs to (from 1), its slot's: a hand is taken up
            only where that person's head is the followed head nearest above it (or no
            head is followed above it).
        result: The target tracker's outcome, in the camera's pixels.
        name: The tracker's slot: ``head``, ``hand``, ``hand_2`` for the first person,
            ``person_2/head``, ... for the others.
    """

    id: int
    kind: str
    person: int
    result: TargetResult
    name: str = ''


def primary_target(
    outcomes: Sequence[TrackedTarget], kind: str, centre: tuple[float, float], chosen_id: int = 0
) -> TrackedTarget:
    """The target a consumer of one target follows among a frame's ``outcomes`` (the tracker
    node's ``pose`` and ``contour``): the target of ``kind`` holding ``chosen_id`` while it is
    followed; else, of the followed targets of ``kind``, the one whose box centre lies nearest
    ``centre`` (x, y, camera pixels: the image's centre, where a robot looks at the person it
    talks to); else the first outcome (the first person's, not followed)."""
    followed = [o for o in outcomes if o.kind == kind and o.result.tracking]
    chosen = [o for o in followed if chosen_id and o.id == chosen_id]
    if chosen:
        return chosen[0]
    if not followed:
        return outcomes[0]
    return min(followed, key=lambda o: float(np.hypot(*np.subtract(box_centre(o.result.estimate.box), centre))))


def targets_line(outcomes: Sequence[TrackedTarget]) -> str:
    """Every target's name, id (- while it has none), state and, for a followed head, where it
    faces: ``head 1 TRACKING away, hand - LOST``."""
    return ', '.join(f'{o.name or o.kind} {o.id or "-"} {state_words(o.result)}' for o in outcomes)


def state_words(result: TargetResult) -> str:
    """A target's state, and where it faces while it is a followed head: ``TRACKING toward``."""
    return f'{result.status} {result.facing}' if result.facing is not None and result.tracking else str(result.status)
