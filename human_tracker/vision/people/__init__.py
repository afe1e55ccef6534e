"""People: a head and its hands per person, each target in a slot with its id."""

from __future__ import annotations

from human_tracker.vision.people.persons import PersonTracker, kinds_of
from human_tracker.vision.people.slots import Slot

__all__ = [
    'PersonTracker',
    'Slot',
    'kinds_of',
]
