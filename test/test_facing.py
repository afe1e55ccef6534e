"""Where a head faces: a run's verdict, what a face needs to be found, the votes of the last runs,
and the scores against labels by eye (``test/data/facing``)."""

from __future__ import annotations

import csv
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import REAL_DATA

from human_tracker.evaluation.facing import LABELS, facing_scores, read_facing, read_labels
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.cues.appearance import colour_bins
from human_tracker.vision.faces.detector import FACE_ON_HEAD, Detection, FaceDetector, face_detector_available
from human_tracker.vision.faces.facing import (
    SMALLEST_SCALE_MARGIN,
    SMALLEST_VISIBLE_FACE,
    VOTING_RUNS,
    FaceLook,
    Facing,
    FacingVotes,
    face_visible,
    facing_after_run,
    size_known,
)
from human_tracker.vision.filter.parameters import TrackerParameters
from human_tracker.vision.geometry.boxes import BoxRelation

TOWARD, SIDE, AWAY, UNKNOWN = Facing.TOWARD, Facing.SIDE, Facing.AWAY, Facing.UNKNOWN


def test_a_run_says_toward_or_side_by_the_filter_that_found_the_face() -> None:
    face = Detection((10.0, 10.0, 40.0, 40.0), 1.0)
    assert facing_after_run(face, visible=True) == TOWARD
    assert facing_after_run(face._replace(view=1), visible=True) == SIDE
    assert facing_after_run(face._replace(view=2), visible=False) == SIDE
    # The frontal filters turned in the image plane: a tilted head still faces the camera.
    assert facing_after_run(face._replace(view=3), visible=True) == TOWARD
    assert facing_after_run(face._replace(view=4), visible=True) == TOWARD


def test_no_face_is_away_only_where_one_would_be_found() -> None:
    assert facing_after_run(None, visible=True) == AWAY
    assert facing_after_run(None, visible=False) == UNKNOWN


def test_a_run_that_misses_a_face_where_it_still_looks_like_one_says_nothing() -> None:
    assert facing_after_run(None, visible=True, looks_like_face=True) is None
    face = Detection((10.0, 10.0, 40.0, 40.0), 1.0)
    assert facing_after_run(face, visible=True, looks_like_face=True) == TOWARD


def _head(face_colour: tuple[int, int, int], place: BoxRelation = FACE_ON_HEAD) -> tuple[np.ndarray, np.ndarray]:
    """A frame's colour bins with a head at a state [x, y, s, θ] whose face's ``place`` is
    painted ``face_colour`` (BGR, with some noise) on a grey-blue background."""
    rng = np.random.default_rng(0)
    image = np.full((120, 160, 3), (120, 90, 60), np.uint8)
    state = np.array([80.0, 50.0, 40.0, 0.0])
    x, y, w, h = (int(v) for v in place.box(state))
    patch = np.array(face_colour, np.int16) + rng.integers(-12, 13, (h, w, 3))
    image[y : y + h, x : x + w] = np.clip(patch, 0, 255).astype(np.uint8)
    return colour_bins(image), state


def test_the_face_look_is_the_face_seen_toward_the_camera_not_the_back_of_the_head() -> None:
    skin, hair = (110, 140, 200), (30, 35, 40)
    face_bins, state = _head(skin)
    hair_bins, _ = _head(hair)
    look = FaceLook()
    assert not look.still_there(face_bins, state, 0.5)  # no face seen yet: a miss may be the back
    look.seen(face_bins, state)
    assert look.still_there(face_bins, state, 0.5)
    assert not look.still_there(hair_bins, state, 0.5)
    assert not look.still_there(face_bins, state + np.array([60.0, 0.0, 0.0, 0.0]), 0.5)  # off the face
    look.clear()
    assert not look.still_there(face_bins, state, 0.5)


def test_the_face_look_is_learnt_and_compared_where_the_head_s_face_sits() -> None:
    """A head whose face sits lower and wider than on the generic head (its ``FacePlace``): the
    look learnt there finds the face there, not a face-coloured patch at the generic place."""
    skin = (110, 140, 200)
    state = np.array([80.0, 50.0, 40.0, 0.0])
    x, y, w, h = FACE_ON_HEAD.box(state)
    own = BoxRelation.of((x - 0.1 * w, y + 0.3 * h, 1.2 * w, 1.2 * h), state)
    face_bins, _ = _head(skin, own)
    elsewhere_bins, _ = _head(skin)
    look = FaceLook()
    look.seen(face_bins, state, own)
    assert look.still_there(face_bins, state, 0.5)
    assert not look.still_there(elsewhere_bins, state, 0.5)


def test_a_face_is_visible_when_big_textured_and_in_the_frame() -> None:
    rng = np.random.default_rng(0)
    textured = rng.integers(0, 256, (120, 160), dtype=np.uint8)
    assert face_visible(textured, (40.0, 40.0, 30.0, 30.0))
    assert not face_visible(textured, (40.0, 40.0, SMALLEST_VISIBLE_FACE - 1, SMALLEST_VISIBLE_FACE - 1))
    assert not face_visible(textured, (145.0, 40.0, 40.0, 40.0))  # mostly out of the frame
    dark = rng.integers(0, 12, (120, 160), dtype=np.uint8)  # a face in the dark: too flat for the detector
    assert not face_visible(dark, (40.0, 40.0, 30.0, 30.0))


def test_a_contour_held_at_the_smallest_scale_does_not_say_how_big_its_face_is() -> None:
    smallest = 24.0
    assert size_known(30.0, smallest, faces_found=0)
    assert not size_known(smallest, smallest, faces_found=0)
    assert not size_known(SMALLEST_SCALE_MARGIN * smallest, smallest, faces_found=0)
    # Faces found on this head were of a size the detector finds: the bound hides nothing.
    assert size_known(smallest, smallest, faces_found=1)


def test_the_votes_give_most_of_the_last_runs_and_the_latest_on_a_tie() -> None:
    votes = FacingVotes()
    assert votes.facing == UNKNOWN
    votes.add(TOWARD)
    votes.add(AWAY)
    assert votes.facing == AWAY  # a tie: the latest
    votes.add(TOWARD)
    assert votes.facing == TOWARD  # one missed face does not turn the head away
    for _ in range(VOTING_RUNS):
        votes.add(SIDE)
    assert votes.facing == SIDE  # only the last runs count
    votes.clear()
    assert votes.facing == UNKNOWN


def test_scores_per_class(tmp_path: Path) -> None:
    labels = {0: TOWARD, 10: TOWARD, 20: SIDE, 30: AWAY}
    runs = [{0: 'toward', 10: 'away', 20: 'side', 30: 'away'}, {0: 'toward', 10: '', 20: 'unknown', 30: 'away'}]
    scores = facing_scores(runs, labels)
    assert scores['facing_toward_precision'] == 1.0 and scores['facing_toward_recall'] == 0.5
    assert scores['facing_away_precision'] == round(2 / 3, 3) and scores['facing_away_recall'] == 1.0
    assert scores['facing_side_precision'] == 1.0 and scores['facing_side_recall'] == 0.5
    assert scores['facing_unknown'] == 0.25
    table = tmp_path / 'poses.csv'
    with table.open('w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(['frame', 'facing', 'kind'])
        writer.writerows([[0, 'toward', 'head'], [0, '', 'hand'], [1, 'away', 'head']])
    assert read_facing(table, offset=5) == {5: 'toward', 6: 'away'}


def test_the_labels_are_every_tenth_frame_in_the_three_classes() -> None:
    for path in sorted(LABELS.glob('*.csv')):
        labels = read_labels(path)
        assert sorted(labels) == list(range(0, 10 * len(labels), 10)), path.name
        assert set(labels.values()) <= {TOWARD, SIDE, AWAY}, path.name
    assert {p.stem for p in LABELS.glob('*.csv')} >= {'girl_turning', 'david_colour', 'cap_and_book'}


@pytest.mark.skipif(not face_detector_available(), reason='dlib absent')
@pytest.mark.skipif(not (REAL_DATA / 'david_colour').is_dir(), reason='real sequences absent')
def test_dlib_tells_a_turned_face_from_a_frontal_one_on_real_frames() -> None:
    """david_colour: frame 300 looks at the camera, frame 450 three-quarters to his left."""
    truth = (REAL_DATA / 'david_colour' / 'groundtruth.txt').read_text().split()
    frames = sorted((REAL_DATA / 'david_colour' / 'img').iterdir())
    detector = FaceDetector()
    for index, expected in ((300, TOWARD), (450, SIDE)):
        grey = cv2.imread(str(frames[index]), cv2.IMREAD_GRAYSCALE)
        box = tuple(float(v) for v in truth[index].split(','))
        (face,) = detector.detect_near(grey, box)
        assert facing_after_run(face, face_visible(grey, face.box)) == expected, index


@pytest.mark.skipif(not face_detector_available(), reason='dlib absent')
@pytest.mark.skipif(not (REAL_DATA / 'crossing').is_dir(), reason='real sequences absent')
def test_a_head_smaller_than_the_smallest_contour_faces_nowhere_known(tmp_path: Path) -> None:
    """crossing: the pedestrian's head is about 6 px wide, the contour held at its smallest scale
    on the walker (24 px) and no face ever found on it: where it faces is unknown, not away."""

    first = tuple(float(v) for v in (REAL_DATA / 'crossing' / 'groundtruth.txt').read_text().split()[0].split(','))
    track_sequence(
        REAL_DATA / 'crossing',
        tmp_path,
        TrackOptions(init=first, progress=False, video=False, filter_parameters=TrackerParameters(seed=1)),
    )
    facing = read_facing(tmp_path / 'poses.csv')
    assert len(facing) == 120
    assert set(facing.values()) <= {'unknown', ''}
