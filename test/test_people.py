"""A person's head and hand followed together, each under its id (vision/people/persons.py)."""

from __future__ import annotations

import csv
import itertools
import json
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import DLIB_MISSING, REAL_DATA, REPO

from human_tracker.cli import main
from human_tracker.io.bags import read_frames
from human_tracker.io.images import to_mono8
from human_tracker.io.poses import POSE_COLUMNS, read_poses
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.ros.image_conversion import message_to_bgr8
from human_tracker.scenes.generator import PEOPLE_TARGETS, SCENES, render_scene
from human_tracker.vision.cues.background import BackgroundModel
from human_tracker.vision.cues.evidence import Evidence, WorkingFrame
from human_tracker.vision.cues.resolution import to_working
from human_tracker.vision.cues.skin import SkinParameters, SkinSegmenter, default_skin_model
from human_tracker.vision.faces.anchoring import FRESH_FACE_FRAMES
from human_tracker.vision.faces.detector import Detection
from human_tracker.vision.filter.contour_filter import TrackerParameters, TrackEstimate
from human_tracker.vision.filter.templates import head_and_shoulders, open_hand
from human_tracker.vision.geometry.boxes import box_centre, centre_within
from human_tracker.vision.people.persons import SAME_REGION, PersonTracker, TrackedTarget, kinds_of, primary_target
from human_tracker.vision.track.lifecycle import LOST, TRACKING
from human_tracker.vision.track.target import TargetResult, TargetTracker, parameters_for

BAGS = REPO / 'bags'


def _frames(name: str, count: int | None = None) -> list:
    return [(f, message_to_bgr8(f.message)) for f in list(read_frames(BAGS / name))[:count]]


def test_the_primary_target_is_the_head_named_or_the_one_nearest_the_centre() -> None:
    """``pose`` and ``contour`` follow one head: the one ``primary_id`` names while it is
    followed; else the followed head nearest the image's centre (hands are not heads); else the
    first person's, followed or not."""

    def target(ident: int, kind: str, person: int, box: tuple[float, ...], status: str = TRACKING) -> TrackedTarget:
        # The choice reads only each estimate's box (x, y, w, h, camera pixels).
        result = TargetResult(status, SimpleNamespace(box=box))  # type: ignore[arg-type]
        return TrackedTarget(ident, kind, person, result, f'person_{person}/{kind}')

    centre = (320.0, 240.0)
    far, near = target(1, 'head', 1, (10, 10, 50, 60)), target(4, 'head', 2, (290, 200, 50, 60))
    hand = target(2, 'hand', 1, (300, 220, 20, 20))  # nearer the centre than either head
    outcomes = [far, hand, near]
    assert primary_target(outcomes, 'head', centre) is near
    assert primary_target(outcomes, 'head', centre, chosen_id=1) is far
    assert primary_target(outcomes, 'head', centre, chosen_id=2) is near  # a hand's id names no head
    assert primary_target(outcomes, 'head', centre, chosen_id=9) is near  # an id no longer followed
    lost = target(0, 'head', 2, (290, 200, 50, 60), LOST)
    assert primary_target([far, hand, lost], 'head', centre) is far
    first_lost = target(0, 'head', 1, (10, 10, 50, 60), LOST)
    assert primary_target([first_lost, hand, lost], 'head', centre) is first_lost


def test_what_is_followed() -> None:
    assert kinds_of('person') == ('head', 'hand') and kinds_of('hand') == ('hand',)
    assert kinds_of('person', hands=2) == ('head', 'hand', 'hand') and kinds_of('head', hands=2) == ('head',)
    with pytest.raises(ValueError, match='target must be one of head, hand, person'):
        kinds_of('crowd')
    with pytest.raises(ValueError, match='hands must be from 0 to 2'):
        kinds_of('person', hands=3)
    for kinds in (('head', 'head'), ('hand', 'head'), ('hand', 'hand'), ('head', 'hand', 'hand', 'hand')):
        with pytest.raises(ValueError, match='kinds must be a head, a hand, or a head and up to 2 hands'):
            PersonTracker(kinds)
    with pytest.raises(ValueError, match='max_people must be >= 1, and 1 without a head'):
        PersonTracker(('hand',), max_people=2)
    people = PersonTracker(('head', 'hand', 'hand'), max_people=2)
    names = ['head', 'hand', 'hand_2', 'person_2/head', 'person_2/hand', 'person_2/hand_2']
    assert [slot.name for slot in people.slots] == names
    assert [t.filter.parameters.seed for t in people.trackers] == list(range(6))  # each its own generator


def test_one_kind_is_exactly_the_target_tracker() -> None:
    """Following one head through PersonTracker changes nothing: same states, same statuses,
    with every cue given (skin labels too)."""
    alone = TargetTracker(head_and_shoulders(), TrackerParameters(seed=3), parameters_for('head'))
    person = PersonTracker(('head',), TrackerParameters(seed=3))
    cues, skin = BackgroundModel(), SkinSegmenter(default_skin_model())
    for _, image in _frames('head_basic', 40):
        motion = cues.apply(to_working(to_mono8(image), 320))
        labels = skin.segment(to_working(image, 320), 0.5)
        expected = alone.process(image, motion, labels)
        (got,) = person.process(image, motion, labels)
        assert got.result.status == expected.status and got.kind == 'head' and got.person == 1
        if expected.estimate is not None:
            np.testing.assert_array_equal(got.result.estimate.state, expected.estimate.state)


def _working_frames(evidence: Evidence) -> int:
    return sum(isinstance(value, WorkingFrame) for value in evidence._working.values())


def test_a_working_frame_computed_beforehand_gives_the_same_track() -> None:
    """A node waiting for a frame's masks computes the frame's working image, bins and edges
    meanwhile (PersonTracker.prepare): with the cues added, they give the track computed without
    them, for a person's head and hands."""
    ahead, after = (PersonTracker(('head', 'hand'), TrackerParameters(seed=2)) for _ in range(2))
    cues, skin = BackgroundModel(), SkinSegmenter(default_skin_model())
    for frame, image in _frames('hand_wave', 30):
        if frame.index == 0:
            for people in (ahead, after):
                people.initialise_from_box(frame.ground_truth, 'hand')
        motion = cues.apply(to_working(to_mono8(image), 320))
        labels = skin.segment(to_working(image, 320), 0.5)
        evidence = Evidence(image)
        ahead.prepare(evidence)
        head_width, hand_width = (slot.tracker.working_width(image.shape[1]) for slot in ahead.slots[:2])
        assert _working_frames(evidence) == 1 and ('reduced', head_width) in evidence._working
        got = ahead.step(evidence.with_cues(motion=motion, skin=labels))
        # The hand's own (colour edges) was added beside the head's, from the same reduced
        # frame while both work at one width (the head found by itself on a small thing: two).
        assert _working_frames(evidence) == 2 and len(evidence._working) == 2 + len({head_width, hand_width})
        expected = after.process(image, motion, labels)
        assert [(o.id, o.kind, o.result.status) for o in got] == [(o.id, o.kind, o.result.status) for o in expected]
        for a, b in zip(got, expected, strict=True):
            if b.result.estimate is not None:
                np.testing.assert_array_equal(a.result.estimate.state, b.result.estimate.state)


def test_an_id_is_given_each_time_a_target_is_taken_up_and_never_again() -> None:
    """head_leave_return: the person is followed, leaves (LOST: no id), comes back: a new id."""
    person = PersonTracker(('head',), TrackerParameters(seed=0))
    cues = BackgroundModel()
    ids, statuses = [], []
    for _, image in _frames('head_leave_return'):
        (outcome,) = person.process(image, cues.apply(to_working(to_mono8(image), 320)))
        ids.append(outcome.id)
        statuses.append(outcome.result.status)
    assert all((i > 0) == (s == 'TRACKING') for i, s in zip(ids, statuses, strict=True))
    runs = [i for k, i in enumerate(ids) if i and (k == 0 or ids[k - 1] != i)]
    assert runs == [1, 2]  # one id per stretch of TRACKING, in order
    assert 'LOST' in statuses[statuses.index('TRACKING') : len(statuses) - statuses[::-1].index('TRACKING')]


def test_the_hand_keeps_off_the_face_found_on_the_head() -> None:
    """The head's tracker finds a face (a stub detector: the synthetic head has none for dlib).
    Where there are more hands than one (here: room for a second person), while that face is
    fresh the hand is handed where the head's contour puts it and runs no detector of its own;
    once it is stale, and before any face, the hand's own detector looks. One person's only
    hand always looks itself."""
    frames = _frames('head_basic', 20)
    for max_people in (2, 1):
        person = PersonTracker(('head', 'hand'), TrackerParameters(seed=0), max_people=max_people)
        head, hand = person.first('head'), person.first('hand')
        assert head.detector is not None, DLIB_MISSING
        first, image = frames[0]
        head.initialise_from_box(first.ground_truth)
        person.process(image)
        assert hand.faces.last_face is None and hand.faces.frames == 1  # no face on the head: the hand's detector ran
        x, y, w, h = first.ground_truth
        face = (x + 0.1 * w, y + 0.15 * h, 0.8 * w, 0.8 * w)  # camera pixels
        found = [Detection(tuple(v * head.scale for v in face), 1.0)]
        head.detector.detect = head.detector.detect_near = lambda *a, found=found, **k: found
        head.detector.localise = lambda image, box: box
        person.process(frames[1][1])  # the head's detector finds the face on this frame
        runs = hand.faces.frames
        for _, image in frames[2:5]:
            head_outcome = person.process(image)[0]
            assert head.frames_without_own_face <= FRESH_FACE_FRAMES
            if max_people == 1:
                assert hand.faces.last_face is None  # the synthetic head has no face for the hand's dlib
            else:
                assert head.face_place.faces > 0  # the place learnt from the stub's faces
                placed = head.face_place.relation.box(head_outcome.result.estimate.state)
                np.testing.assert_allclose(np.array(hand.faces.last_face) / hand.scale, placed, atol=1e-6)
        assert hand.faces.frames == runs + (3 if max_people == 1 else 0)  # handed the face, its detector did not run
        if max_people == 1:
            continue
        head.detector.detect = head.detector.detect_near = lambda *a, **k: []
        for _, image in frames[5 : 7 + FRESH_FACE_FRAMES]:
            head_outcome = person.process(image)[0]
        assert head.frames_without_own_face > FRESH_FACE_FRAMES
        assert PersonTracker._face_of(head, head_outcome.result) is None and hand.faces.frames > runs


def test_a_hand_on_another_persons_face_is_lost() -> None:
    """A face handed to a hand as another person's (``avoid``) is kept off as its own: a contour
    on it is a weak frame, LOST after ``lost_frames`` of them, and the hand starts again only
    off it; the same hand without it stays."""
    frames = _frames('hand_wave', 12)
    segmenter = SkinSegmenter(default_skin_model())
    outcomes: dict[bool, list[TargetResult]] = {False: [], True: []}
    for avoided in outcomes:
        hand = TargetTracker(open_hand(), TrackerParameters(seed=0), parameters_for('hand'))
        hand.initialise_from_box(frames[0][0].ground_truth)
        for frame, image in frames:
            face = frame.ground_truth  # someone's face just where the hand is
            skin = segmenter.segment(to_working(image, 320), 0.5)
            outcomes[avoided].append(hand.process(image, None, skin, avoid=[face] if avoided else []))
    lost_frames = parameters_for('hand').lost_frames
    assert {r.status for r in outcomes[False]} == {'TRACKING'}
    statuses = [r.status for r in outcomes[True]]
    assert statuses[: lost_frames - 1] == ['TRACKING'] * (lost_frames - 1) and statuses[lost_frames - 1] == 'LOST'
    for (frame, _), result in list(zip(frames, outcomes[True], strict=True))[lost_frames:]:
        assert result.status == 'LOST' or not centre_within(result.estimate.box, frame.ground_truth)


def test_a_restart_far_from_the_target_is_a_new_id() -> None:
    """A filter restarted farther than the target's width from its last estimate follows
    someone else (another face, another person): a new id; a restart nearer, the same target."""
    person = PersonTracker(('head',))
    slot = person.slots[0]
    slot.last_state = np.array([100.0, 100.0, 40.0, 0.0])

    def restarted_at(x: float) -> TargetResult:
        estimate = TrackEstimate(
            np.array([x, 100.0, 40.0, 0.0]), np.eye(4), 0.8, 0.5, 100.0, (0, 0, 1, 1), np.zeros((1, 2))
        )
        return TargetResult('TRACKING', estimate, initialised=True)

    assert slot.jumped(restarted_at(141.0)) and not slot.jumped(restarted_at(139.0))
    assert not slot.jumped(TargetResult('TRACKING', restarted_at(141.0).estimate))  # not restarted


def _estimate(x: float, y: float = 100.0, scale: float = 40.0) -> TrackEstimate:
    box = (x - scale / 2, y - scale / 2, scale, scale)
    return TrackEstimate(np.array([x, y, scale, 0.0]), np.eye(4), 0.8, 0.5, 100.0, box, np.zeros((1, 2)))


def test_a_target_taken_up_again_near_where_it_was_lost_keeps_its_id() -> None:
    """A LOST target reports no id but its id is held for ``id_hold_frames``: taken up again
    within ``HOLD_REACH`` widths of where it was last followed it gets it back; farther, or
    later, a new one."""
    for back_at, after, same in ((170.0, 15, True), (190.0, 10, False), (170.0, 16, False)):
        person = PersonTracker(('hand',), id_hold_frames=15)
        slot = person.slots[0]
        first = person._identify(slot, TargetResult('TRACKING', _estimate(100.0), initialised=True))
        assert first.tracking and slot.id == 1
        for k in range(after):  # the filter wanders while LOST
            assert person._identify(slot, TargetResult('LOST', _estimate(100.0 + k))).status == 'LOST'
            assert slot.id == 0
        person._identify(slot, TargetResult('TRACKING', _estimate(back_at), initialised=True))
        assert (slot.id == 1) == same and slot.id > 0, (back_at, after)
        assert slot.held_id == 0  # taken up: nothing held any more


def test_a_persons_only_hand_keeps_its_id_while_their_head_is_followed() -> None:
    """Every hand a person's only hand slot may take up is that person's: while their head is
    followed it keeps its id through a restart three widths away and a loss of 40 frames
    ending anywhere. Without the head followed, or with two hand slots, the usual rules: a
    new id for each."""
    for hands, head_followed, same in ((1, True, True), (1, False, False), (2, True, False)):
        person = PersonTracker(('head',) + ('hand',) * hands, id_hold_frames=15)
        slot = person.slot('hand')
        person.slot('head').box = (80.0, 0.0, 40.0, 40.0) if head_followed else None
        person._identify(slot, TargetResult('TRACKING', _estimate(100.0), initialised=True))
        first = slot.id
        person._identify(slot, TargetResult('TRACKING', _estimate(220.0), initialised=True))  # restarted
        assert (slot.id == first) == same, (hands, head_followed)
        first = slot.id
        for _ in range(40):
            person._identify(slot, TargetResult('LOST', _estimate(220.0)))
        person._identify(slot, TargetResult('TRACKING', _estimate(20.0), initialised=True))
        assert (slot.id == first) == same and slot.id > 0, (hands, head_followed)


def test_a_later_persons_head_needs_a_face_and_a_hand_its_persons_head() -> None:
    """A second person's head is taken up only with a face found on it (the first person's
    by its contour too); a hand only where its own person's head is the followed head nearest
    above it. A slot that never took a target up and may not take this one stays WAITING; one
    that did is LOST."""
    people = PersonTracker(('head', 'hand'), max_people=2)
    first, second = people.slot('head'), people.slot('person_2/head')
    assert second.tracker.detector is not None, DLIB_MISSING
    result = TargetResult('TRACKING', _estimate(300.0, 60.0), initialised=True)
    assert people._identify(second, result).status == 'WAITING' and second.id == 0
    assert second.tracker.status == 'WAITING'
    second.tracker.faces.last_face, second.tracker.frames_without_own_face = (290.0, 50.0, 20.0, 20.0), 0
    assert people._identify(second, result).tracking and second.id == 1
    assert people._identify(first, TargetResult('TRACKING', _estimate(100.0, 60.0), initialised=True)).tracking
    first_hand, second_hand = people.slot('hand'), people.slot('person_2/hand')
    near_second = TargetResult('TRACKING', _estimate(280.0, 160.0), initialised=True)
    assert people._identify(first_hand, near_second).status == 'WAITING' and first_hand.id == 0
    assert people._identify(second_hand, near_second).tracking and second_hand.id == 3
    # Taken up once (by its own person's head), the first hand is LOST where it may not be.
    assert people._identify(first_hand, TargetResult('TRACKING', _estimate(110.0, 160.0), initialised=True)).tracking
    first_hand.tracker.status = 'TRACKING'
    assert people._identify(first_hand, near_second).status == 'LOST' and first_hand.id == 0


def test_a_hand_keeps_off_its_own_face_hidden_behind_another_person() -> None:
    """The faces a hand keeps off besides its own: the other people's followed heads'; and its
    own person's, where no face is handed for it now but one was found on the head before,
    only among other people (alone, the hand itself hides it)."""
    own, other = (100.0, 50.0, 40.0, 40.0), (300.0, 60.0, 40.0, 40.0)
    avoid = PersonTracker._faces_to_avoid
    assert avoid(1, {1: own}, {1}, None) == []
    assert avoid(1, {1: own, 2: other}, {1, 2}, own) == [other]  # handed: its own detector is off
    assert avoid(1, {1: own, 2: other}, {1, 2}, None) == [other, own]
    assert avoid(1, {1: own, 2: other}, {2}, None) == [other]  # a head never seen with a face
    assert avoid(2, {1: own, 2: other}, {1, 2}, None) == [own, other]


def test_track_a_person_offline(tmp_path, capsys) -> None:
    """hand_wave with --target person: a row per target per frame with its id, kind and person;
    the head and the hand start by themselves, the hand is scored against the hand's truth, by
    ``track`` and by ``eval``."""
    summary = track_sequence(BAGS / 'hand_wave', tmp_path, TrackOptions(target='person', progress=False))
    rows = list(csv.DictReader((tmp_path / 'poses.csv').open()))
    assert tuple(rows[0]) == POSE_COLUMNS and len(rows) == 2 * summary['frames']
    assert [r['kind'] for r in rows[:2]] == ['head', 'hand']
    head_ids = {r['id'] for r in rows if r['kind'] == 'head' and r['id']}
    hand_ids = {r['id'] for r in rows if r['kind'] == 'hand' and r['id']}
    assert head_ids and hand_ids and not head_ids & hand_ids
    # Each row names the shape the target is drawn in: the bag's hand is open. In front of the
    # skin-coloured furniture (frames 64-80) its labels join the furniture's, which the closed
    # hand's contour fits as well (on 0-16 of those frames, seeds 0-9).
    hand_shapes = [
        r['shape']
        for r in rows
        if r['kind'] == 'hand' and r['status'] == 'TRACKING' and not 64 <= int(r['frame']) <= 80
    ]
    assert {r['shape'] for r in rows if r['kind'] == 'head' and r['shape']} == {'head_and_shoulders'}
    assert hand_shapes.count('open_hand') > 0.95 * len(hand_shapes)
    assert summary['scored_kind'] == 'hand' and summary['precision_20px'] >= 0.95
    assert summary['targets']['head']['longest_id_share'] >= 0.9
    assert json.loads((tmp_path / 'summary.json').read_text())['targets'] == summary['targets']
    assert (tmp_path / 'tracking.mp4').stat().st_size > 0
    with pytest.raises(ValueError, match=r'follows a person \(head, hand\): name the kind'):
        read_poses(tmp_path / 'poses.csv')
    assert len(read_poses(tmp_path / 'poses.csv', 'hand')) == summary['frames']
    assert main(['eval', str(tmp_path / 'poses.csv'), str(BAGS / 'hand_wave')]) == 0
    scored = json.loads(capsys.readouterr().out)
    assert scored['scored_kind'] == 'hand' and scored['precision_20px'] == summary['precision_20px']
    # One hand id, on the hand from its first frame: no switch, as `track` counted.
    assert summary['id_switches'] == scored['id_switches'] == 0 and scored['idf1'] == summary['idf1'] >= 0.95
    # A start box goes to the target it is named for; the other starts by itself.
    box = next(f.ground_truth for f, _ in _frames('hand_wave', 1))
    options = TrackOptions(target='person', init=box, init_kind='hand', video=False, progress=False)
    track_sequence(BAGS / 'hand_wave', tmp_path / 'boxed', options)
    first = list(csv.DictReader((tmp_path / 'boxed' / 'poses.csv').open()))[:2]
    assert [(r['kind'], r['status']) for r in first] == [('head', 'WAITING'), ('hand', 'TRACKING')]
    with pytest.raises(ValueError, match='init_kind must be one of head, hand'):
        track_sequence(BAGS / 'hand_wave', tmp_path / 'bad', TrackOptions(target='person', init=box, init_kind='foot'))


@pytest.mark.skipif(not (REAL_DATA / 'hand2').exists(), reason='the real sequences are not beside the repository')
def test_a_real_person_head_and_hand_start_by_themselves(tmp_path) -> None:
    """hand2 (a man waving beside his face, a second man at a desk behind him), no box: the head
    is taken up on the first frames and the hand soon after (seed 0: the head also restarts onto
    the man behind while the hand hides the face, frames 78-89, under an id of its own)."""
    options = TrackOptions(target='person', video=False, progress=False)
    summary = track_sequence(REAL_DATA / 'hand2', tmp_path, options)
    rows = list(csv.DictReader((tmp_path / 'poses.csv').open()))
    heads = [r for r in rows if r['kind'] == 'head']
    hands = [r for r in rows if r['kind'] == 'hand']
    print(summary['precision_20px'], summary['targets'], {k: summary[k] for k in ('mota', 'idf1', 'id_switches')})
    assert next(i for i, r in enumerate(heads) if r['id']) < 5
    assert next(i for i, r in enumerate(hands) if r['id']) < 30
    # Issue 16's goal for the hand of a person started by itself (0.663 measured at seed 0).
    assert summary['scored_kind'] == 'hand' and summary['precision_20px'] >= 0.6


def test_two_people_crossing_are_scored_track_by_track(tmp_path) -> None:
    """people_crossing: a bag with three ground-truth tracks (the head and hand of the person who
    steps in and waves, the head of the person walking across in front). `track` follows a
    person, and scores each track and every target against every track (MOTA, IDF1, switches).
    One person: the head takes the one who steps in first and keeps one id; while the walker's
    head hides their face (frames 100-124) it follows the walker's face instead, a
    follower of one person has no one else to give it to."""
    frames = list(read_frames(BAGS / 'people_crossing'))
    assert all(set(f.ground_truths) == set(PEOPLE_TARGETS) for f in frames)
    rendered = list(render_scene(SCENES['people_crossing']))
    for frame, truth in zip(frames, rendered, strict=True):
        for name, box in truth.targets.items():
            assert (box is None) == (frame.ground_truths[name] is None)
            if box is not None:
                np.testing.assert_allclose(frame.ground_truths[name], box, atol=1e-3)
    summary = track_sequence(BAGS / 'people_crossing', tmp_path, TrackOptions(video=False, progress=False))
    assert summary['target'] == 'person' and set(summary['tracks']) == set(PEOPLE_TARGETS)
    assert summary['tracks']['person_1/head']['precision_20px'] >= 0.75
    assert summary['targets']['head']['ids'] == 1 and 'person_2/head' not in summary['targets']


@pytest.mark.parametrize('seed', [0, 8, 16])
def test_two_people_each_keep_their_head_and_id(tmp_path, seed: int) -> None:
    """people_crossing with two people: the second person's head is looked for away from the
    first's, so each head is held under one id while the walker crosses in front of the first;
    no two targets of a kind are ever reported on one region (the occupancy rule), and a target
    is LOST only after it was TRACKING (seed 8: the walker's hand slot, kept off the waving hand
    on the frame it first took it up, said LOST for 3 frames before). The hand keeps off both
    faces, and gets its id back when it comes out from behind the walker's head: no identity
    switch, IDF1 at least 0.9. Seed 16: the hand is lost behind the walker's head on frame 63;
    its filter, once carried away on the walker's face (0.387), finds it again as it comes out
    (the faces a hand keeps off are not skin to it)."""
    options = TrackOptions(max_people=2, filter_parameters=TrackerParameters(seed=seed), video=False, progress=False)
    summary = track_sequence(BAGS / 'people_crossing', tmp_path, options)
    print(summary['tracks'], summary['all_tracks'], summary['targets'])
    assert summary['tracks']['person_1/head']['precision_20px'] >= 0.95
    assert summary['tracks']['person_2/head']['precision_20px'] >= 0.9
    assert summary['tracks']['person_1/hand']['precision_20px'] >= 0.9
    assert summary['targets']['head']['ids'] == summary['targets']['person_2/head']['ids'] == 1
    assert summary['all_tracks']['id_switches'] == 0 and summary['all_tracks']['idf1'] >= 0.9
    rows = list(csv.DictReader((tmp_path / 'poses.csv').open()))
    assert {r['target'] for r in rows} == {'head', 'hand', 'person_2/head', 'person_2/hand'}
    followed_since_waiting: dict[str, bool] = {}
    for r in rows:
        assert r['status'] != 'LOST' or followed_since_waiting.get(r['target']), r
        if r['status'] != 'LOST':
            followed_since_waiting[r['target']] = r['status'] == 'TRACKING'
    followed: dict[tuple[str, str], list[tuple[float, ...]]] = {}
    for r in rows:
        if r['status'] == 'TRACKING':
            followed.setdefault((r['frame'], r['kind']), []).append(
                tuple(float(r[k]) for k in ('box_x', 'box_y', 'box_w', 'box_h'))
            )
    for (_, kind), boxes in followed.items():
        assert not any(centre_within(a, b, SAME_REGION[kind]) for a, b in itertools.permutations(boxes, 2))


def test_the_occupancy_rule_keeps_the_target_taken_up_first() -> None:
    """Two heads on one region: the later id is marked LOST, its id retired, or, where its slot
    takes a target up for the first time on this frame, it goes on WAITING (a never-followed
    target is never LOST); apart, or one behind the other (a centre in the other's box, outside
    its central half), both stay. A second hand takes its turn only while the first is
    followed; a second person only while the first has a head."""
    people = PersonTracker(('head', 'hand', 'hand'), max_people=2)
    first, second = people.slot('head'), people.slot('person_2/head')
    estimate = TrackEstimate(
        np.array([50.0, 50.0, 40.0, 0.0]), np.eye(4), 0.8, 0.5, 100.0, (0, 0, 1, 1), np.zeros((1, 2))
    )
    for slot, identity, box in ((first, 3, (10.0, 10.0, 40.0, 40.0)), (second, 5, (15.0, 12.0, 40.0, 40.0))):
        slot.id, slot.box = identity, box
        slot.tracker.status = 'TRACKING'
    ran = [(first, TargetResult('TRACKING', estimate)), (second, TargetResult('TRACKING', estimate))]
    kept = people._keep_apart(ran, waiting=[])
    assert [r.status for _, r in kept] == ['TRACKING', 'LOST']
    assert (second.id, second.box, second.tracker.status) == (0, None, 'LOST') and first.id == 3
    second.id, second.box, second.taken_up = 5, (15.0, 12.0, 40.0, 40.0), True
    second.tracker.status = 'TRACKING'
    kept = people._keep_apart(ran, waiting=[second])
    assert [r.status for _, r in kept] == ['TRACKING', 'WAITING']
    assert (second.id, second.tracker.status, second.taken_up) == (0, 'WAITING', False)
    for box in ((100.0, 15.0, 40.0, 40.0), (25.0, 20.0, 40.0, 40.0)):  # apart; one behind the other
        second.id, second.box = 5, box
        assert [r.status for _, r in people._keep_apart(ran, waiting=[])] == ['TRACKING', 'TRACKING']
    assert not people._runs(people.slot('hand_2')) and people._runs(people.slot('hand'))
    people.slot('hand').box = (0.0, 0.0, 9.0, 9.0)
    assert people._runs(people.slot('hand_2')) and people._runs(people.slot('person_2/hand'))
    first.box = None
    second.box = None
    assert not people._runs(people.slot('person_2/head')) and not people._runs(people.slot('person_2/hand'))


def test_a_hand_on_the_forearm_below_another_hand_is_lost() -> None:
    """Two hands: one whose centre lies below the other's box, within the box's own height (its
    wrist and forearm), is on that arm: the later one is marked LOST; beside it, or lower down,
    both stay."""
    people = PersonTracker(('head', 'hand', 'hand'))
    first, second = people.slot('hand'), people.slot('hand_2')
    estimate = TrackEstimate(
        np.array([50.0, 50.0, 40.0, 0.0]), np.eye(4), 0.8, 0.5, 100.0, (0, 0, 1, 1), np.zeros((1, 2))
    )
    ran = [(first, TargetResult('TRACKING', estimate)), (second, TargetResult('TRACKING', estimate))]
    for box, kept in (
        ((100.0, 140.0, 40.0, 40.0), False),
        ((150.0, 140.0, 40.0, 40.0), True),
        ((100.0, 200.0, 40.0, 40.0), True),
    ):
        first.id, first.box = 3, (100.0, 100.0, 40.0, 40.0)
        second.id, second.box = 5, box
        second.tracker.status = 'TRACKING'
        statuses = [r.status for _, r in people._keep_apart(ran, waiting=[])]
        assert statuses == ['TRACKING', 'TRACKING' if kept else 'LOST'] and first.id == 3


def test_a_person_started_from_a_box_is_kept_while_another_walks_past(tmp_path) -> None:
    """people_crossing from the still person's head box: the box names the target, so neither the
    waving hand nor the walker, both moving more, takes the head over while the walker is away
    (they did before: 0.02). Once the walker's head hides the face (from frame 94), their face,
    the one found, draws the filter, whose motion-weighted edges it then fits better: a single
    target's tracker follows the walker on some of the frames left."""
    frames = list(read_frames(BAGS / 'people_crossing'))
    options = TrackOptions(target='head', init=frames[0].ground_truths['person_1/head'], video=False, progress=False)
    summary = track_sequence(BAGS / 'people_crossing', tmp_path, options)
    for frame, box in list(zip(frames, read_poses(tmp_path / 'poses.csv'), strict=True))[:94]:
        truth = frame.ground_truths['person_1/head']
        assert box is not None and np.hypot(*np.subtract(box_centre(box), box_centre(truth))) <= 20.0
    assert summary['tracks']['person_1/head']['precision_20px'] >= 0.75


def test_a_persons_hands_reduce_the_frame_once() -> None:
    """Trackers with the same working width and edge settings share one working frame (the
    same arrays as computing it alone); the head, which fits grey edges, has its own, and the
    frame reduced to the working width once serves the head's colour bins and the hands' edges."""
    image = _frames('people_crossing', 1)[0][1]
    person = PersonTracker(('head', 'hand', 'hand'))
    head, first, second = person.trackers
    evidence = Evidence(image)
    frames = [evidence.working(tracker.frame_settings(image.shape[1])) for tracker in (head, first, second)]
    assert frames[2] is frames[1] and frames[1] is not frames[0] and _working_frames(evidence) == 2
    kept = evidence._working
    assert set(kept) - {k for k, v in kept.items() if isinstance(v, WorkingFrame)} == {('reduced', 320)}
    hand = TargetTracker(open_hand(), parameters=parameters_for('hand'))
    alone = Evidence(image).working(hand.frame_settings(image.shape[1]))
    assert all(np.array_equal(a, b) for a, b in zip(alone[:3], frames[2][:3], strict=True))
    assert frames[2].bins is None and frames[0].edges.shape == frames[2].edges.shape


def test_a_held_id_comes_back_only_to_its_own_slot_where_it_may_take_up(tmp_path) -> None:
    """people_crossing with two people, seed 9, skin cells merged by colour: the waving hand is
    lost in front of the walker's face (frame 62) and its filter settles on a skin-coloured
    square below the walker's head, which is not its person's to take up, even under the id
    held for it (it was: an identity switch, the hand 0.393); when the hand comes out, the
    walker's hand slot, which finds it first, leaves it to the slot holding its id."""
    options = TrackOptions(
        max_people=2,
        filter_parameters=TrackerParameters(seed=9),
        skin_parameters=SkinParameters(merge_distance=10.0),
        video=False,
        progress=False,
    )
    summary = track_sequence(BAGS / 'people_crossing', tmp_path, options)
    print(summary['tracks'], summary['all_tracks'])
    assert summary['all_tracks']['id_switches'] == 0 and summary['all_tracks']['idf1'] >= 0.9
    assert summary['tracks']['person_1/hand']['precision_20px'] >= 0.7
    hands = {r['id'] for r in csv.DictReader((tmp_path / 'poses.csv').open()) if r['target'] == 'hand' and r['id']}
    assert len(hands) == 1  # one id for the waving hand from its first frame to its last
