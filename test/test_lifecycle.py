"""A track's life: every state change by its event, and what makes a frame weak, hand-checked."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from human_tracker.vision.track.lifecycle import (
    FIT_MEMORY,
    LOST,
    TRACKING,
    WAITING,
    Event,
    TrackState,
    UsualFit,
    back_where_lost,
    transition,
    weak_frame,
)
from human_tracker.vision.track.parameters import LossParameters


@pytest.mark.parametrize(
    ('state', 'event', 'after'),
    [
        (WAITING, Event.START, TRACKING),
        (LOST, Event.START, TRACKING),
        (WAITING, Event.START_UNCONFIRMED, WAITING),  # never taken up: never lost
        (LOST, Event.START_UNCONFIRMED, LOST),
        (TRACKING, Event.START_UNCONFIRMED, LOST),
        (LOST, Event.RESTART, TRACKING),
        (TRACKING, Event.LOSS, LOST),
        (WAITING, Event.LOSS, WAITING),  # a declined hypothesis's weak frames: still waiting
        (LOST, Event.RECOVERY, TRACKING),
        (WAITING, Event.RECOVERY, WAITING),  # only a lost target recovers
        (TRACKING, Event.RECOVERY, TRACKING),
        (TRACKING, Event.MARK_LOST, LOST),
        (WAITING, Event.MARK_LOST, WAITING),  # never taken up: nothing to lose
        (LOST, Event.MARK_LOST, LOST),
        (TRACKING, Event.RESET, WAITING),
        (LOST, Event.RESET, WAITING),
    ],
)
def test_each_event_moves_the_state_as_the_life_of_a_track_says(state, event, after) -> None:
    assert transition(state, event) is after


def test_the_state_is_the_status_word_everywhere() -> None:
    assert [str(s) for s in TrackState] == ['WAITING', 'TRACKING', 'LOST'] and f'{TRACKING}' == 'TRACKING'
    assert TRACKING == 'TRACKING'  # a status read back from poses.csv compares equal


def test_the_usual_fit_is_a_running_mean_then_forgets_over_fit_memory() -> None:
    usual = UsualFit()
    assert not usual.below(0.0, 0.25)  # nothing to fall below yet
    usual.add(0.8)
    usual.add(0.6)
    assert usual.mean == pytest.approx(0.7)
    for _ in range(10 * FIT_MEMORY):
        usual.add(0.4)
    assert usual.mean == pytest.approx(0.4, abs=1e-3)
    assert usual.below(0.29, 0.25) and not usual.below(0.31, 0.25)


def _estimate(confidence: float, appearance_distance: float = 0.2, motion_support: float = 0.5) -> SimpleNamespace:
    return SimpleNamespace(
        confidence=confidence, appearance_distance=appearance_distance, motion_support=motion_support, skin_support=1.0
    )


def test_a_frame_is_weak_by_the_silhouettes_evidence_and_a_change_of_colour_alone_is_not() -> None:
    """Without a motion mask, colours unlike the target's make a frame weak only with the edge
    fit fallen below its usual; with a mask (a way back through the moving region) they do
    while the target's colours are in view beside the contour, not when they are gone from
    around it (the person turned round)."""
    p = LossParameters(lost_confidence=0.3, lost_motion_support=0.2, lost_appearance_distance=0.5, lost_fit_drop=0.25)
    usual = UsualFit()
    usual.add(0.8)  # weak below 0.6 where nothing else vouches for the contour
    mask = np.ones((4, 4), np.uint8)
    no_mask = SimpleNamespace(motion=None, likelihood_skin=None)
    with_mask = SimpleNamespace(motion=mask, likelihood_skin=None)
    assert weak_frame(_estimate(0.25), p, with_mask, False, usual)  # too few points on edges
    assert weak_frame(_estimate(0.7, motion_support=0.1), p, with_mask, False, usual)  # off the moving region
    # A person turning round: the colours change, the silhouette fits as usual.
    assert not weak_frame(_estimate(0.75, appearance_distance=0.8), p, no_mask, True, usual)
    assert weak_frame(_estimate(0.75, appearance_distance=0.8), p, with_mask, True, usual)
    # The fit fallen: weak without a mask, or with colours unlike the target's, not otherwise.
    assert weak_frame(_estimate(0.55), p, no_mask, True, usual)
    assert not weak_frame(_estimate(0.55), p, with_mask, True, usual)
    assert weak_frame(_estimate(0.55, appearance_distance=0.8), p, with_mask, True, usual)
    assert not weak_frame(_estimate(0.55, appearance_distance=0.8), p, with_mask, False, usual)  # appearance unknown
    # The colours gone from around a contour that fits: the target itself changed.
    gone, beside = (lambda: False), (lambda: True)
    assert not weak_frame(_estimate(0.75, appearance_distance=0.8), p, with_mask, True, usual, gone)
    assert weak_frame(_estimate(0.75, appearance_distance=0.8), p, with_mask, True, usual, beside)
    assert weak_frame(_estimate(0.55, appearance_distance=0.8), p, with_mask, True, usual, gone)  # the fit fallen too


def test_a_lost_head_is_back_where_it_was_lost_after_twice_lost_frames_steady() -> None:
    """Back: its contour held for 2 ``lost_frames`` frames, within its width of where it was
    lost and at that size (within 1.25). Not back: sooner, never lost, moved more than its width,
    or grown or shrunk beyond the factor."""
    parameters = LossParameters(lost_frames=5)
    lost_at = np.array([100.0, 80.0, 40.0, 0.0])
    here = np.array([120.0, 110.0, 45.0, 0.1])  # 36 px away, 1.125 times the size
    assert back_where_lost(here, lost_at, 10, parameters)
    assert not back_where_lost(here, lost_at, 9, parameters)
    assert not back_where_lost(here, None, 50, parameters)
    assert not back_where_lost(np.array([130.0, 110.0, 40.0, 0.0]), lost_at, 50, parameters)  # 42 px
    assert not back_where_lost(np.array([100.0, 80.0, 51.0, 0.0]), lost_at, 50, parameters)
    assert not back_where_lost(np.array([100.0, 80.0, 31.0, 0.0]), lost_at, 50, parameters)
