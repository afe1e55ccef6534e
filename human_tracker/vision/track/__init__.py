"""One target's track: its state (WAITING, TRACKING, LOST) and the one function that moves it,
how it starts (§2.5), its constants by concern, and the step that runs its filter on a frame's
evidence.
"""

from __future__ import annotations

from human_tracker.vision.track.lifecycle import LOST, TRACKING, WAITING, TrackState, transition
from human_tracker.vision.track.outcomes import TargetResult, TrackedTarget, primary_target, state_words, targets_line
from human_tracker.vision.track.parameters import TargetParameters, parameters_for
from human_tracker.vision.track.state import Track
from human_tracker.vision.track.target import TargetTracker

__all__ = [
    'LOST',
    'TRACKING',
    'TargetParameters',
    'TargetResult',
    'TargetTracker',
    'Track',
    'TrackState',
    'TrackedTarget',
    'WAITING',
    'parameters_for',
    'primary_target',
    'state_words',
    'targets_line',
    'transition',
]
