"""A track's life: its state, the one function that changes it, and the tests that feed it.

A target is WAITING (never taken up, or reset; its filter may try a hypothesis), TRACKING, or
LOST (taken up once, not followed now; its filter may still hold an estimate). Every change of a target's state is
:func:`transition` applied to an :class:`Event`: a reader can list every way a track starts
and ends here. A target is LOST after ``lost_frames`` weak frames in a row
(:func:`weak_frame`), and TRACKING again when its evidence holds (:func:`recovers`,
:func:`back_where_lost`), or when a face or a hypothesis restarts it
(:mod:`~human_tracker.vision.track.target`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from human_tracker.vision.cues.evidence import Cues
    from human_tracker.vision.filter.contour_filter import TrackEstimate
    from human_tracker.vision.track.parameters import LossParameters

__all__ = [
    'FIT_MEMORY',
    'LOST',
    'TRACKING',
    'WAITING',
    'Event',
    'TrackState',
    'UsualFit',
    'back_where_lost',
    'recovers',
    'transition',
    'weak_frame',
]

FIT_MEMORY = 30
"""Frames over which :class:`UsualFit` forgets (its exponential mean's time constant)."""
WHERE_LOST_SIZE = 1.25
"""A head back where it was lost is within this factor of the size it was lost at."""


class TrackState(StrEnum):
    """A target's state; its value is the status word of ``poses.csv``, ``status`` and ``/diagnostics``."""

    WAITING = 'WAITING'
    TRACKING = 'TRACKING'
    LOST = 'LOST'


WAITING, TRACKING, LOST = TrackState.WAITING, TrackState.TRACKING, TrackState.LOST


class Event(Enum):
    """What happened to a target on a frame (or between frames)."""

    START = 'a box was given, or a hypothesis taken up'
    START_UNCONFIRMED = 'a hypothesis was taken up on a head whose face was seen: lost until a face is found on it'
    RESTART = 'a face was found where the filter had no or a weak target'
    LOSS = 'weak for lost_frames frames in a row, or a face was found under a hand'
    RECOVERY = "a lost target's evidence holds again"
    MARK_LOST = 'told from outside: a gap in time, or another target holds it'
    DECLINE = 'told from outside: a target never taken up may not be taken up here (a later person without a face)'
    RESET = 'the target is forgotten'


_TO = {
    Event.START: TRACKING,
    Event.START_UNCONFIRMED: LOST,
    Event.RESTART: TRACKING,
    Event.LOSS: LOST,
    Event.RESET: WAITING,
    Event.DECLINE: WAITING,
}


def transition(state: TrackState, event: Event) -> TrackState:
    """The state after ``event``: only a followed target can be marked lost, only a lost one
    recovers, and a target never taken up (WAITING) is never LOST: a filter whose hypothesis
    was declined goes on waiting whatever its evidence. Every other event sets its state
    whatever the state before."""
    if event is Event.MARK_LOST:
        return LOST if state == TRACKING else state
    if event is Event.RECOVERY:
        return TRACKING if state == LOST else state
    if _TO[event] == LOST and state == WAITING:
        return WAITING
    return _TO[event]


@dataclass
class UsualFit:
    """The edge fit a followed target usually has: the mean share of its contour's points on
    edges over its steady frames, the last :data:`FIT_MEMORY` weighing most."""

    mean: float | None = None
    frames: int = 0

    def add(self, confidence: float) -> None:
        """A steady frame's fit: a running mean at first, then exponential."""
        self.frames += 1
        rate = max(1.0 / self.frames, 1.0 / FIT_MEMORY)
        self.mean = confidence if self.mean is None else (1.0 - rate) * self.mean + rate * confidence

    def below(self, confidence: float, drop: float) -> bool:
        """Whether ``confidence`` lies more than the share ``drop`` below the usual fit."""
        return self.mean is not None and confidence < (1.0 - drop) * self.mean


def weak_frame(
    estimate: TrackEstimate,
    parameters: LossParameters,
    cues: Cues,
    appearance_known: bool,
    usual: UsualFit,
    colours_beside: Callable[[], bool] = lambda: True,
) -> bool:
    """Whether a frame is weak, by the silhouette's own evidence: too few contour points on
    edges (``lost_confidence``), on moving pixels with a motion mask (``lost_motion_support``),
    or skin inside the contour with skin labels in the likelihood (``lost_skin_support``); an
    edge fit fallen ``lost_fit_drop`` below the ``usual`` one with no motion mask to say where
    the person is (the edge fit alone slides onto clutter: a panning camera); or colours unlike
    the target's known appearance (``lost_appearance_distance``) with the fit fallen too, or
    with a motion mask while ``colours_beside`` says the target's colours are still in view
    beside the contour (it slid off the target onto something else that moves; without the
    callable, taken to be in view). A change of colour alone is weak evidence: with the
    colours gone from around a contour that fits, the target itself changed (a person turned
    round); and without a mask a head LOST on it would come back only through a face, while
    with one a lost target comes back through the moving region (:func:`recovers`)."""
    p = parameters
    fallen = usual.below(estimate.confidence, p.lost_fit_drop)
    recoloured = appearance_known and estimate.appearance_distance > p.lost_appearance_distance
    return (
        estimate.confidence < p.lost_confidence
        or (cues.motion is not None and estimate.motion_support < p.lost_motion_support)
        or (cues.likelihood_skin is not None and estimate.skin_support < p.lost_skin_support)
        or (recoloured and (fallen or (cues.motion is not None and colours_beside())))
        or (fallen and cues.motion is None)
    )


def recovers(
    weak_frames: int, steady_frames: int, parameters: LossParameters, *, region: bool, faces: bool, skin: bool
) -> bool:
    """Whether a LOST target is TRACKING again by its own evidence. Without a ``region`` cue
    (motion, skin) the edge fit is the only evidence, unless ``faces`` are the proposals (a lost
    head comes back through one); with a region, a lost target comes back through a hypothesis
    (an edge fit on clutter is not the person), or, with ``skin`` labels, after ``lost_frames``
    frames in a row that are not weak (skin labels flicker off a hand for a few frames)."""
    by_edges = weak_frames == 0 and not region and not faces
    return by_edges or (skin and steady_frames >= parameters.lost_frames)


def back_where_lost(
    state: np.ndarray, lost_at: np.ndarray | None, steady_frames: int, parameters: LossParameters
) -> bool:
    """Whether a LOST head is TRACKING again where it was lost: its contour has held for twice
    ``lost_frames`` frames in a row that are not weak, its estimate ``state`` (x, y, scale, θ)
    within its width (``scale``) of the state ``lost_at`` it was lost at, and of that size
    (within :data:`WHERE_LOST_SIZE`). A head lost while nothing moved it away (a book raised in
    front of the face, colours changing with a motion mask) is the same person; one lost and
    carried elsewhere comes back only through a face or a hypothesis."""
    if lost_at is None or steady_frames < 2 * parameters.lost_frames:
        return False
    ratio = state[2] / lost_at[2]
    near = np.hypot(state[0] - lost_at[0], state[1] - lost_at[1]) <= lost_at[2]
    return bool(near and 1 / WHERE_LOST_SIZE <= ratio <= WHERE_LOST_SIZE)
