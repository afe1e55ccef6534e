"""Following people's heads and hands together, each target under a stable id.

The paper's introduction asks for "the determination of the person's pose as well as the
location of the hand(s)". A person here is a head (head-and-shoulders contour) and up to two
hands (open or closed hand contours), each its own :class:`~human_tracker.vision.track.target.TargetTracker`
over the same frame's evidence; up to ``max_people`` people are followed. On each frame:

- **Heads first.** A hand keeps off faces (a face is skin of about a hand's size), so it uses
  what the heads found. Where there is more than one hand slot, a hand is handed where its
  person's head puts the face while a face has just been found on that head
  (:meth:`PersonTracker._face_of`), instead of running its own detector; every hand keeps off
  where the other people's followed heads put their faces, and, among other people, its own
  person's face while it is hidden (:meth:`PersonTracker._faces_to_avoid`). One person's only
  hand looks itself.
- **Apart.** A target is handed the boxes the other targets of its kind hold (a hand's with
  the forearm below it): no start, hypothesis or face proposal inside one. The occupancy rule
  catches a filter that drifts onto another's region: when the centre of one target lies in
  the central half of another head's box (the whole box of another hand), the one taken up
  later is marked LOST (still WAITING where its slot takes a target up for the first time) and
  looks again elsewhere.
- **Turns.** A second hand runs only while the first is followed, the next person's head only
  while the person before has a head, their hands only while their own head is followed: an
  idle slot costs nothing. A person after the first is taken up only by a face found on their
  head, a hand only where its own person's head is the followed head nearest above it
  (:meth:`PersonTracker._may_take_up`).

Ids: every time a target is taken up (TRACKING after WAITING or LOST, or restarted farther than
its width from where it was) it gets a new id, never reused while the tracker lives. A LOST
target reports no id, but its id is held for ``id_hold_frames``: taken up again by its own slot
(:mod:`~human_tracker.vision.people.slots`) within ``HOLD_REACH`` widths of where it was, it gets it
back (a hand that passed behind someone's head). A person's only hand keeps its id however
long and far it was lost, or wherever it restarted, while their head is followed: every hand
it may take up is that person's. A consumer that sees the same id on two frames sees the same
target. What each rule was measured against: docs/decisions/two-people.md
and hand2-as-a-person.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.faces.detector import FaceDetector, face_detector_available
from human_tracker.vision.faces.finder import FaceFinder
from human_tracker.vision.filter.contour_filter import TrackerParameters
from human_tracker.vision.filter.templates import ContourTemplate, make_template
from human_tracker.vision.geometry.boxes import Box, box_centre, centre_within
from human_tracker.vision.people.slots import Slot
from human_tracker.vision.track.outcomes import TargetResult, TrackedTarget, primary_target, targets_line
from human_tracker.vision.track.target import TargetParameters, TargetTracker, parameters_for

__all__ = ['KINDS', 'TARGETS', 'PersonTracker', 'TrackedTarget', 'kinds_of', 'primary_target', 'targets_line']

KINDS = ('head', 'hand')
TARGETS = (*KINDS, 'person')
"""What a tracker follows: one head, one hand, or a person (a head and hands)."""

# Two targets of a kind are on one region when the centre of one lies in this central share of
# the other's box: for heads its half (a head behind another overlaps its box more than
# that); for hands the whole box (two hands that close are one: with the half, hand2 with two
# hands 0.48 -> 0.41).
SAME_REGION = {'head': 0.5, 'hand': 1.0}

MAX_HANDS = 2
"""The most hands a person has."""


def kinds_of(target: str, hands: int = 1) -> tuple[str, ...]:
    """The kinds of target one person of ``target`` (``head``, ``hand`` or ``person``) has; a
    person has a head and ``hands`` hands (0 to :data:`MAX_HANDS`)."""
    if target not in TARGETS:
        raise ValueError(f'target must be one of {", ".join(TARGETS)}, got {target!r}')
    if not 0 <= hands <= MAX_HANDS:
        raise ValueError(f'hands must be from 0 to {MAX_HANDS}, got {hands}')
    return ('head',) + ('hand',) * hands if target == 'person' else (target,)


@dataclass
class PersonTracker:
    """One :class:`TargetTracker` per target of ``kinds`` for each of up to ``max_people``
    people over the same frames, with ids.

    Args:
        kinds: One person's targets: ``('head',)``, ``('hand',)``, or a head and one or two
            hands (:func:`kinds_of`).
        filter_parameters: The particle filters' constants (each target's own generator is
            seeded from ``seed`` + its slot's place, so a run is reproducible).
        parameters: Each kind's cue and loss constants (:func:`parameters_for` where absent).
        templates: Each kind's contour (the built-in one where absent).
        max_people: The most people followed at once (from 1; more than one needs a head,
            by which a person is found).
        id_hold_frames: LOST frames a target's id is held for it (0: a target taken up again
            always gets a new id). Half a second at 30 Hz: about the time a hand or a face is
            hidden by someone walking past.
    """

    kinds: tuple[str, ...] = ('head',)
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    parameters: dict[str, TargetParameters] = field(default_factory=dict)
    templates: dict[str, ContourTemplate] = field(default_factory=dict)
    max_people: int = 1
    id_hold_frames: int = 15
    slots: list[Slot] = field(init=False)
    last_id: int = field(default=0, init=False)
    face_finder: FaceFinder | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        allowed = [('hand',), *(('head',) + ('hand',) * hands for hands in range(MAX_HANDS + 1))]
        if self.kinds not in allowed:
            raise ValueError(f'kinds must be a head, a hand, or a head and up to {MAX_HANDS} hands, got {self.kinds}')
        if self.max_people < 1 or (self.max_people > 1 and 'head' not in self.kinds):
            raise ValueError(f'max_people must be >= 1, and 1 without a head, got {self.max_people}')
        if self.id_hold_frames < 0:
            raise ValueError(f'id_hold_frames must be >= 0, got {self.id_hold_frames}')
        self.slots = []
        wanted = {kind: self.parameters.get(kind) or parameters_for(kind) for kind in self.kinds}
        if any(p.wants_faces for p in wanted.values()) and face_detector_available():
            # One detector for every target: their searches of a frame run together.
            self.face_finder = FaceFinder(FaceDetector(), any(p.detector_thread for p in wanted.values()))
        for person in range(1, self.max_people + 1):
            for place, kind in enumerate(self.kinds):
                hand = self.kinds[: place + 1].count('hand')
                name = kind if hand < 2 else f'{kind}_{hand}'
                name = name if person == 1 else f'person_{person}/{name}'
                seed = self.filter_parameters.seed + len(self.slots)
                tracker = TargetTracker(
                    self.templates.get(kind) or make_template(kind),
                    replace(self.filter_parameters, seed=seed),
                    wanted[kind],
                    face_finder=self.face_finder,
                )
                if person > 1 and kind == 'head':
                    # A later person is taken up only on a face (_may_take_up), not on the
                    # moving region as the first may be: until one is found, their search also
                    # finds faces too small for the whole-frame search
                    # (docs/decisions/later-people-small-faces.md).
                    tracker.faces.small_faces = True
                self.slots.append(Slot(name, person, kind, hand, tracker))

    @property
    def trackers(self) -> list[TargetTracker]:
        """Every slot's tracker, in the slots' order."""
        return [slot.tracker for slot in self.slots]

    def slot(self, name: str) -> Slot:
        """The slot named ``name`` (:attr:`TrackedTarget.name`)."""
        return next(slot for slot in self.slots if slot.name == name)

    def first(self, kind: str) -> TargetTracker:
        """The first person's tracker of ``kind`` (its first hand for ``hand``)."""
        return next(slot.tracker for slot in self.slots if slot.kind == kind)

    @property
    def hands_handed_faces(self) -> bool:
        """Whether the hands are handed their person's face by its head (more than one hand
        slot: a second hand, other people) rather than find it themselves (module docstring)."""
        return sum(slot.kind == 'hand' for slot in self.slots) > 1

    @property
    def uses_skin(self) -> bool:
        """Whether a target's tracker wants skin labels (a hand's)."""
        return 'hand' in self.kinds

    def initialise_from_box(self, box: tuple[float, float, float, float], kind: str | None = None) -> None:
        """Start the first person's ``kind`` (the first of ``kinds`` when None) on a box (x, y,
        w, h), camera pixels; the others start by themselves."""
        self.first(kind or self.kinds[0]).initialise_from_box(box)

    def prepare(self, evidence: Evidence) -> None:
        """Compute the first target's working frame of ``evidence`` (its reduced image, colour
        bins and edges): a node waiting for the frame's cues computes it meanwhile, then adds
        them (:meth:`~human_tracker.vision.cues.evidence.Evidence.with_cues`)."""
        evidence.working(self.slots[0].tracker.frame_settings(evidence.image.shape[1]))

    def reset(self) -> None:
        """Forget every target; the ids already given stay retired."""
        for slot in self.slots:
            self._clear(slot)

    def process(
        self,
        image: np.ndarray,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
        camera_motion: np.ndarray | None = None,
        stamp_ns: int | None = None,
    ) -> list[TrackedTarget]:
        """:meth:`step` on the evidence of ``image`` and its cues."""
        return self.step(Evidence(image, motion, skin, camera_motion, stamp_ns))

    def step(self, evidence: Evidence) -> list[TrackedTarget]:
        """Track every target on one frame's ``evidence``; beside a hand, the skin labels go to
        the hands only (a head-and-shoulders outline is not skin).

        Returns:
            One outcome per slot that runs on this frame (the first person's always), in the
            slots' order.
        """
        ran: list[tuple[Slot, TargetResult]] = []
        waiting = [slot for slot in self.slots if not slot.taken_up]  # never taken up before this frame
        faces: dict[int, Box | None] = {}  # by person
        followed: dict[int, Box] = {}  # where each followed head puts its face
        faced: set[int] = set()  # the people whose followed head a face was found on
        # Heads first: a hand keeps off the faces they find, every person's.
        order = sorted(self.slots, key=lambda o: o.kind != 'head')
        if self.face_finder is not None:
            self.face_finder.new_frame()
        for place, slot in enumerate(order):
            if self.face_finder is not None:
                # A face search waits for those of the targets of its kind after it on this frame
                # (on the same working image: face_finder).
                later = [o for o in order[place + 1 :] if o.kind == slot.kind]
                self.face_finder.hold = any(o.tracker.faces.due(o.tracker.parameters) for o in later)
            if not self._runs(slot):
                if slot.tracker.filter.initialised:
                    self._clear(slot)  # its turn is over: it starts afresh when it comes again
                continue
            tracker = slot.tracker
            # A hand keeps off the other hands and the forearm below them (one with no hand of
            # its person in view took up the wrist under another's).
            exclude = [
                o.held_region() for o in self.slots if o is not slot and o.kind == slot.kind and o.box is not None
            ]
            if slot.kind == 'head':
                own = evidence if len(self.kinds) == 1 else evidence.with_cues(skin=None)
                # Identified before the hands look: a head this slot may not take up (a later
                # person's without a face) is not followed, no one's face to hand over or keep off.
                found = tracker.step(own, exclude=exclude)
                result = self._identify(slot, found)
                if self.hands_handed_faces:
                    faces[slot.person] = self._face_of(tracker, result)
                if result.tracking:
                    followed[slot.person] = tracker.face_place.relation.box(result.estimate.state)
                    if tracker.anchor.face_relation is not None:
                        faced.add(slot.person)
            else:
                face = faces.get(slot.person)
                avoid = self._faces_to_avoid(slot.person, followed, faced, face)
                found = tracker.step(evidence, face=face, exclude=exclude, avoid=avoid)
                result = self._identify(slot, found)
            ran.append((slot, result))
        if self.face_finder is not None:
            self.face_finder.submit()
        ran = self._keep_apart(sorted(ran, key=lambda run: self.slots.index(run[0])), waiting)
        return [TrackedTarget(slot.id, slot.kind, slot.person, result, slot.name) for slot, result in ran]

    def _identify(self, slot: Slot, result: TargetResult) -> TargetResult:
        """The slot's id and box after its tracker's ``result`` on this frame; the result, not
        TRACKING for a target the slot may not take up (:meth:`_may_take_up`): WAITING while the
        slot never took one up, else LOST."""
        keeps = self._persons_hand(slot)
        if result.tracking and slot.jumped(result) and not (keeps and self._may_take_up(slot, result)):
            slot.id = 0  # another target now: the one followed is gone
        if result.tracking and slot.id == 0:
            if not self._may_take_up(slot, result):
                if slot.taken_up:
                    slot.tracker.mark_lost()
                else:
                    slot.tracker.decline()  # never taken up: it still waits
                result = replace(result, status=slot.tracker.status)
            elif slot.holds(result.estimate.state, anywhere=keeps):
                slot.id = slot.held_id
            else:
                self.last_id += 1
                slot.id = self.last_id
            if slot.id:
                slot.retire()
                slot.taken_up = True
        elif not result.tracking and slot.id:
            if self.id_hold_frames and slot.last_state is not None:
                slot.held_id, slot.held_state, slot.held_frames = slot.id, slot.last_state, 1
            slot.id = 0
        elif not result.tracking and slot.held_id:
            slot.held_frames += 1
            if slot.held_frames > self.id_hold_frames and not keeps:
                slot.retire()
        if result.estimate is not None:
            slot.last_state = result.estimate.state
        slot.box = result.estimate.box if result.tracking else None
        return result

    def _persons_hand(self, slot: Slot) -> bool:
        """Whether ``slot`` is its person's only hand and their head is followed: every hand it
        takes up is then that person's (:meth:`_may_take_up`), and keeps the id, however far
        and long it was lost (a consumer reading the person's gesture keys it by the id)."""
        return (
            slot.kind == 'hand'
            and self.kinds.count('hand') == 1
            and any(o.person == slot.person and o.kind == 'head' and o.box is not None for o in self.slots)
        )

    def _may_take_up(self, slot: Slot, result: TargetResult) -> bool:
        """Whether a target new to ``slot`` is one it may follow: a later person's head only
        with a face found on it (taken up on the moving region, one settled on the first
        person's waving fingers before the second person came in); a hand only where its own
        person's head is the nearest above it (the walker's slot, whose hands are out of view,
        took the waving hand of the person behind: theirs to take up); neither where another
        slot of its kind holds an id for a target lost there (:meth:`~human_tracker.vision.people.slots.Slot.holds`)."""
        state = result.estimate.state
        held = [o for o in self.slots if o is not slot and o.kind == slot.kind and o.held_frames <= self.id_hold_frames]
        if any(other.holds(state) for other in held):
            return False
        if slot.kind == 'head':
            return slot.person == 1 or slot.tracker.detector is None or slot.tracker.has_fresh_face
        return self._person_above(result.estimate.box) in (None, slot.person)

    @staticmethod
    def _faces_to_avoid(person: int, followed: dict[int, Box], faced: set[int], face: Box | None) -> list[Box]:
        """The faces a hand of ``person`` keeps off besides its own (``avoid``): where the other
        people's followed heads put theirs (``followed``, by person), found on them lately or
        not (one half hidden behind the walker's head took up a hand). Among other people, the
        person's own too while it is not handed (``face`` None: no face found on their head
        lately) though one was found on it before (``faced``): hidden behind someone, a hand
        restarted on the first person's forehead behind the walker's head. Alone, it is the
        hand that hides it, and it may pass in front."""
        avoid = [box for other, box in followed.items() if other != person]
        if avoid and face is None and person in faced:
            avoid.append(followed[person])
        return avoid

    def _runs(self, slot: Slot) -> bool:
        """Whether ``slot`` takes its turn on this frame: the first person's head and first hand
        always; a second hand while the first is followed; another person's head while the
        person before has a head followed, their first hand while their own head is followed;
        any target while it is followed itself."""
        if slot.box is not None:
            return True
        # The slot it waits for: the first hand of a second; a later person's head the head of
        # the person before, their hand their own head (without it, skin of the room or of a
        # face not yet found starts hands no one has: people_crossing's walker).
        waits_for = [
            o
            for o in self.slots
            if (o.person == slot.person and slot.hand > 1 and o.hand == slot.hand - 1)
            or (slot.kind == 'head' and o.person == slot.person - 1 and o.kind == 'head')
            or (slot.hand == 1 and slot.person > 1 and o.person == slot.person and o.kind == 'head')
        ]
        return all(o.box is not None for o in waits_for)

    def _keep_apart(self, ran: list[tuple[Slot, TargetResult]], waiting: list[Slot]) -> list[tuple[Slot, TargetResult]]:
        """The occupancy rule: of two followed targets of a kind where one's centre lies inside
        the region the other holds (the central ``SAME_REGION`` share of its box; a hand's box
        with the forearm below it), the one taken up later (the higher id) is marked LOST, or
        declined (still WAITING) where its slot was ``waiting``: never taken up before this frame."""
        kept = []
        for slot, result in ran:
            box, share = slot.box, SAME_REGION[slot.kind]
            taken = box is not None and any(
                other.kind == slot.kind
                and other.box is not None
                and other.id < slot.id
                and (
                    centre_within(box, other.held_region(), share)
                    or centre_within(other.box, slot.held_region(), share)
                )
                for other, _ in ran
            )
            if taken:
                if any(slot is other for other in waiting):
                    slot.tracker.decline()
                    slot.taken_up = False
                else:
                    slot.tracker.mark_lost()
                slot.id, slot.box = 0, None
                slot.retire()
                result = replace(result, status=slot.tracker.status)
            kept.append((slot, result))
        return kept

    def _person_above(self, box: Box) -> int | None:
        """The person whose followed head is nearest above ``box`` (x, y, w, h), None without one."""
        x, y = box_centre(box)
        heads = [o for o in self.slots if o.kind == 'head' and o.box is not None and box_centre(o.box)[1] < y]
        if not heads:
            return None
        return min(heads, key=lambda o: float(np.hypot(*np.subtract(box_centre(o.box), (x, y))))).person

    def _clear(self, slot: Slot) -> None:
        slot.tracker.reset()
        slot.id, slot.last_state, slot.box, slot.taken_up = 0, None, None, False
        slot.retire()

    @staticmethod
    def _face_of(head: TargetTracker, result: TargetResult) -> tuple[float, float, float, float] | None:
        """Where the person's face is (x, y, w, h, camera pixels): where the head's contour puts it
        while a face has just been found on it, else None (a head that slid onto the raised arm
        would send the hand to the face): the hand's own detector looks then."""
        return head.face_place.relation.box(result.estimate.state) if result.tracking and head.has_fresh_face else None
