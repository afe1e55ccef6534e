"""A track's life: its state and the one function that changes it.

A target is WAITING (never taken up, or reset), TRACKING, or LOST (taken up once, not followed
now; its filter may still hold an estimate). Every change of a target's state is
:func:`transition` applied to an :class:`Event` that the tracker's tests name; a reader can
list every way a track starts and ends here.
"""

from __future__ import annotations

from enum import Enum, StrEnum

__all__ = ['TrackState', 'Event', 'transition', 'WAITING', 'TRACKING', 'LOST']


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
    RESTART = 'a face was found where the filter had no, a weak or a faceless target'
    LOSS = 'weak for lost_frames frames in a row, or a face was found under a hand'
    RECOVERY = "a lost target's evidence holds again"
    MARK_LOST = 'told from outside: a gap in time, or another target holds it'
    RESET = 'the target is forgotten'


_TO = {
    Event.START: TRACKING,
    Event.START_UNCONFIRMED: LOST,
    Event.RESTART: TRACKING,
    Event.LOSS: LOST,
    Event.RESET: WAITING,
}


def transition(state: TrackState, event: Event) -> TrackState:
    """The state after ``event``: only a followed target can be marked lost, only a lost one
    recovers; every other event sets its state whatever the state before."""
    if event is Event.MARK_LOST:
        return LOST if state == TRACKING else state
    if event is Event.RECOVERY:
        return TRACKING if state == LOST else state
    return _TO[event]
