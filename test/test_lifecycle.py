"""A track's life: every state change by its event, hand-checked."""

from __future__ import annotations

import pytest

from human_tracker.vision.lifecycle import LOST, TRACKING, WAITING, Event, TrackState, transition


@pytest.mark.parametrize(
    ('state', 'event', 'after'),
    [
        (WAITING, Event.START, TRACKING),
        (LOST, Event.START, TRACKING),
        (WAITING, Event.START_UNCONFIRMED, LOST),
        (TRACKING, Event.START_UNCONFIRMED, LOST),
        (LOST, Event.RESTART, TRACKING),
        (TRACKING, Event.LOSS, LOST),
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
