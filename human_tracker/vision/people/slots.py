"""A target's slot in a person tracker: its tracker, and its id between frames."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from human_tracker.vision.geometry.boxes import Box
from human_tracker.vision.track.outcomes import TargetResult
from human_tracker.vision.track.target import TargetTracker

__all__ = ['HOLD_REACH', 'Slot']

HOLD_REACH = 2.0
"""How far from where a LOST target was last followed, in its widths (its scale), it may be
taken up again under its held id."""


@dataclass
class Slot:
    """One target's tracker and what is known of it between frames.

    Attributes:
        name: ``head``, ``hand``, ``hand_2``; ``person_<n>/`` before it from the second person.
        person: The person it was made for (from 1).
        kind: ``head`` or ``hand``.
        hand: Which of the person's hands (1 or 2; 0 for a head).
        tracker: Its target tracker.
        id: Its current id (0 while not followed).
        last_state: Its last estimate's state, camera pixels.
        box: Its box on the last frame it was followed (camera pixels), None otherwise.
        held_id: The id it had when it was LOST, while that may come back (0: none).
        held_state: Its state on the last frame it was followed, camera pixels.
        held_frames: Frames it has been LOST.
        taken_up: Whether its target has had an id since the slot was last cleared: one that
            may not be taken up is then LOST, else still WAITING.
    """

    name: str
    person: int
    kind: str
    hand: int
    tracker: TargetTracker
    id: int = 0
    last_state: np.ndarray | None = None
    box: tuple[float, float, float, float] | None = None
    held_id: int = 0
    held_state: np.ndarray | None = None
    held_frames: int = 0
    taken_up: bool = False

    def holds(self, state: np.ndarray, anywhere: bool = False) -> bool:
        """Whether the slot holds an id for a target lost within :data:`HOLD_REACH` widths (its
        scale then) of ``state`` (x, y, scale, θ; camera pixels), or ``anywhere``."""
        held = self.held_state
        if held is None:
            return False
        return anywhere or float(np.hypot(*(state[:2] - held[:2]))) <= HOLD_REACH * held[2]

    def held_region(self) -> Box:
        """The region its followed target holds (x, y, w, h, camera pixels): its box, and for a
        hand its own height below it too, where its wrist and forearm are."""
        assert self.box is not None
        x, y, w, h = self.box
        return (x, y, w, 2.0 * h) if self.kind == 'hand' else self.box

    def jumped(self, result: TargetResult) -> bool:
        """Whether its filter restarted farther than the target's width (its scale) from its
        last estimate."""
        last = self.last_state
        if not result.initialised or last is None or result.estimate is None:
            return False
        return float(np.hypot(*(result.estimate.state[:2] - last[:2]))) > last[2]

    def retire(self) -> None:
        """Forget the id held for its LOST target."""
        self.held_id = self.held_frames = 0
        self.held_state = None
