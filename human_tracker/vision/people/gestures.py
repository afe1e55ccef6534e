"""Gestures from a person's hand tracks, read against their own head (the paper's purpose, §1:
"the robot must also be able to follow a person's gestures"; the hand tracks of Brèthes et al.,
ICRA 2004).

Each followed hand's box centre is measured from its person's followed head: ``across`` in head
widths (positive to the image's right, the person's left when they face the camera) and
``down`` in head heights from the head's place, the median of its centres over the last
``window`` seconds (a head estimate pulled along by the hand passing before the face for a
moment does not carry the reference with it). From those, on every frame:

- **Waving**: the hand swings from side to side. A swing is a leg of the hand's ``across``
  path between two turning points at least ``swing`` head widths apart (a zig-zag filter: a
  turning point is confirmed once the hand has come back that far from it). Waving starts when
  ``min_swings`` swings ended within the last ``window`` seconds and lasts while one did.
- **A hand raised**: its centre above the head's top (``down`` < -1/2): ``LEFT_HAND_RAISED`` or
  ``RIGHT_HAND_RAISED`` by the side of the head it is on, ``BOTH_HANDS_RAISED`` for two.
- **Hands on the face**: a hand's centre within the head box's central half.

The names and numbers are ROS4HRI's (``hri_msgs/Gesture``). One gesture is reported at a time
(waving before a raised hand, a raised hand before hands on the face); a new one replaces the
reported one only once it has been seen for ``hold`` seconds, and the reported one ends only
once it has been gone that long, so that a gesture does not flicker.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from human_tracker.vision.geometry.boxes import Box, box_centre
from human_tracker.vision.track.outcomes import TrackedTarget

__all__ = ['Gesture', 'GestureParameters', 'GestureReading', 'Gestures', 'PersonGestures']


class Gesture(IntEnum):
    """A body's gesture, numbered as ``hri_msgs/Gesture``'s constants (NONE is ours: no gesture)."""

    NONE = -1
    OTHER = 0
    HANDS_ON_FACE = 1
    ARMS_CROSSED = 2
    LEFT_HAND_RAISED = 3
    RIGHT_HAND_RAISED = 4
    BOTH_HANDS_RAISED = 5
    WAVING = 6

    def __str__(self) -> str:
        return '' if self is Gesture.NONE else self.name.lower()


@dataclass(frozen=True)
class GestureParameters:
    """Constants of the gesture reading.

    Attributes:
        window: Seconds over which waving's swings are counted (a wave's period is 0.5-3 s).
        swing: Head widths a swing must cover (a hand gesturing while its person talks moves
            less than its head's width).
        min_swings: Swings within ``window`` that start waving.
        longest_swing: Seconds a swing may take at most (waving is quick: half a period).
        hold: Seconds a gesture must be seen before it is reported, and gone before it ends.
        gap: Seconds without a followed hand (or head) after which the hand's path starts over.
    """

    window: float = 2.0
    swing: float = 1.0
    min_swings: int = 2
    longest_swing: float = 1.0
    hold: float = 0.3
    gap: float = 0.5


@dataclass(frozen=True)
class GestureReading:
    """A person's reported gesture.

    Attributes:
        gesture: The gesture (:attr:`Gesture.NONE` when none).
        confidence: In [0, 1]: for waving, the swings within the window over three; else the
            share of the last ``hold`` seconds' frames that showed it.
        since_ns: When it started (the stamp of the first frame it was seen on), 0 for NONE.
    """

    gesture: Gesture = Gesture.NONE
    confidence: float = 0.0
    since_ns: int = 0


@dataclass
class _HandPath:
    """One hand's ``across`` path: the zig-zag filter's state and the swings' end stamps."""

    last_ns: int = 0
    start: float | None = None
    direction: int = 0  # +1 the hand goes right, -1 left, 0 not yet known
    extreme: float = 0.0  # the farthest ``across`` since the last turning point
    extreme_ns: int = 0
    turned_ns: int = 0  # the last turning point's stamp (the path's start before the first)
    swings: deque[int] = field(default_factory=deque)

    def add(self, stamp_ns: int, across: float, p: GestureParameters) -> None:
        if self.start is None or stamp_ns - self.last_ns > p.gap * 1e9:
            self.start, self.direction, self.turned_ns = across, 0, stamp_ns
            self.swings.clear()
        self.last_ns = stamp_ns
        if self.direction == 0:
            if abs(across - self.start) >= p.swing:
                self.direction = 1 if across > self.start else -1
                self.extreme, self.extreme_ns = across, stamp_ns
            return
        if (across - self.extreme) * self.direction > 0:
            self.extreme, self.extreme_ns = across, stamp_ns  # still going the same way
        elif abs(across - self.extreme) >= p.swing:
            # Back by a swing from the extreme: the extreme was a turning point. The leg that
            # ended there is a swing if it was quick (a hand drifting across is not waving).
            if self.extreme_ns - self.turned_ns <= p.longest_swing * 1e9:
                self.swings.append(self.extreme_ns)
            self.direction, self.turned_ns = -self.direction, self.extreme_ns
            self.extreme, self.extreme_ns = across, stamp_ns
        while self.swings and stamp_ns - self.swings[0] > p.window * 1e9:
            self.swings.popleft()


class PersonGestures:
    """One person's gesture over frames: :meth:`update` with their head and hands on each frame."""

    def __init__(self, parameters: GestureParameters | None = None) -> None:
        self.parameters = parameters or GestureParameters()
        self.reset()

    def update(self, stamp_ns: int, head: Box | None, hands: dict[str, Box]) -> GestureReading:
        """The reading after a frame at ``stamp_ns`` (ns) with the person's followed ``head``
        box (None when it is not followed) and followed ``hands`` (boxes by the hand's slot
        name); boxes ``(x, y, w, h)`` in camera pixels."""
        p = self.parameters
        seen, confidence = Gesture.NONE, 0.0
        if head is not None and head[2] > 0 and head[3] > 0:
            self._heads.append((stamp_ns, *box_centre(head)))
            while stamp_ns - self._heads[0][0] > p.window * 1e9:
                self._heads.popleft()
            cx, cy = (float(np.median([h[axis] for h in self._heads])) for axis in (1, 2))
            places = {}
            for name, box in hands.items():
                hx, hy = box_centre(box)
                places[name] = ((hx - cx) / head[2], (hy - cy) / head[3])
                self._paths.setdefault(name, _HandPath()).add(stamp_ns, places[name][0], p)
            swings = max((len(path.swings) for name, path in self._paths.items() if name in hands), default=0)
            self._waving = swings >= (1 if self._waving else p.min_swings)
            raised = [across for across, down in places.values() if down < -0.5]
            if self._waving:
                seen, confidence = Gesture.WAVING, min(1.0, swings / 3.0)
            elif len(raised) >= 2:
                seen = Gesture.BOTH_HANDS_RAISED
            elif raised:
                # The image's right is the person's left when they face the camera.
                seen = Gesture.LEFT_HAND_RAISED if raised[0] > 0 else Gesture.RIGHT_HAND_RAISED
            elif any(abs(across) < 0.25 and abs(down) < 0.25 for across, down in places.values()):
                seen = Gesture.HANDS_ON_FACE
        else:
            self._waving = False
        return self._report(stamp_ns, seen, confidence)

    def _report(self, stamp_ns: int, seen: Gesture, waving_confidence: float) -> GestureReading:
        """The reported reading, changed only by what was seen for ``hold`` seconds."""
        hold_ns = self.parameters.hold * 1e9
        self._seen.append((stamp_ns, seen))
        while stamp_ns - self._seen[0][0] > hold_ns:
            self._seen.popleft()
        share = sum(g == seen for _, g in self._seen) / len(self._seen)
        confidence = waving_confidence if seen is Gesture.WAVING else share
        if seen == self.reading.gesture:
            self._pending = None
            if seen is not Gesture.NONE:
                self.reading = GestureReading(seen, confidence, self.reading.since_ns)
            return self.reading
        if self._pending is None or self._pending[0] != seen:
            self._pending = (seen, stamp_ns)
        if stamp_ns - self._pending[1] >= hold_ns:
            since = 0 if seen is Gesture.NONE else self._pending[1]
            self.reading = GestureReading(seen, 0.0 if seen is Gesture.NONE else confidence, since)
            self._pending = None
        return self.reading

    def reset(self) -> None:
        """Forget the paths and the reading."""
        self._paths: dict[str, _HandPath] = {}
        self._heads: deque[tuple[int, float, float]] = deque()  # (stamp, centre x, y) over ``window``
        self._seen: deque[tuple[int, Gesture]] = deque()  # (stamp, gesture seen) over ``hold``
        self._waving = False
        self._pending: tuple[Gesture, int] | None = None  # a gesture seen, not yet reported, since
        self.reading = GestureReading()


class Gestures:
    """Every person's gesture, read from a frame's outcomes
    (:class:`~human_tracker.vision.track.outcomes.TrackedTarget`)."""

    def __init__(self, parameters: GestureParameters | None = None) -> None:
        self.parameters = parameters or GestureParameters()
        self._people: dict[int, PersonGestures] = {}

    def update(self, stamp_ns: int, outcomes: Sequence[TrackedTarget]) -> dict[int, GestureReading]:
        """Each person's reading after the frame at ``stamp_ns`` (ns), by person number; a
        person whose head is not followed reads NONE."""
        readings = {}
        for person in sorted({o.person for o in outcomes}):
            mine = [o for o in outcomes if o.person == person and o.result.tracking]
            head = next((o.result.estimate.box for o in mine if o.kind == 'head'), None)
            hands = {o.name: o.result.estimate.box for o in mine if o.kind == 'hand'}
            tracker = self._people.setdefault(person, PersonGestures(self.parameters))
            readings[person] = tracker.update(stamp_ns, head, hands)
        return readings

    def reset(self) -> None:
        """Forget every person's gesture."""
        self._people.clear()
