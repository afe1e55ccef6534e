"""Identity metrics (MOTA, IDF1, switches) against hand-computed values, and read back from poses.csv."""

from __future__ import annotations

import csv

import pytest
from conftest import REAL_DATA

from human_tracker.evaluation.identity import identity_scores, one_id_share, one_track
from human_tracker.evaluation.several_people import REAL_PAIR, side_by_side
from human_tracker.io.poses import POSE_COLUMNS, read_ids
from human_tracker.io.sequences import open_sequence
from human_tracker.offline import TrackOptions, track_sequence

BOX = (100.0, 100.0, 40.0, 40.0)


def test_a_lost_frame_and_a_new_id_by_hand() -> None:
    """Four annotated frames: id 1 twice, nothing, then id 2 on the target.
    MOTA = 1 - (1 miss + 0 false + 1 switch) / 4 = 0.5; IDF1 maps the truth to id 1:
    2 true, 2 missed (frames 3, 4), 1 false (id 2): 2 * 2 / (2 * 2 + 2 + 1) = 4 / 7."""
    scores = identity_scores({'truth': [BOX] * 4}, one_track([1, 1, 0, 2], [BOX, BOX, None, BOX]))
    assert scores == {'mota': 0.5, 'idf1': round(4 / 7, 4), 'id_switches': 1}


def test_one_id_share_by_hand() -> None:
    """Ten frames: id 3 on six, lost on one, id 4 on three: the head is held under one id on
    6 of 10 frames; never reported: 0."""
    assert one_id_share([3, 3, 3, 0, 4, 4, 4, 3, 3, 3]) == pytest.approx(0.6)
    assert one_id_share([0, 0, 0]) == 0.0
    assert one_id_share([]) == 0.0


def test_far_boxes_and_unannotated_frames() -> None:
    """A box 30 px off is a miss and a false report (MOTA 1 - 2/2 = 0 on the one annotated frame
    it is on); frames without truth do not count."""
    off = (130.0, 100.0, 40.0, 40.0)
    scores = identity_scores({'truth': [BOX, BOX, None]}, one_track([1, 1, 1], [BOX, off, off]))
    assert scores['id_switches'] == 0
    assert scores['mota'] == pytest.approx(1.0 - 2 / 2)  # frame 2: one miss, one false report
    assert scores['idf1'] == pytest.approx(2 * 1 / (2 * 1 + 1 + 1), abs=1e-4)


def test_a_table_without_ids_is_one_track(tmp_path) -> None:
    """The demo's table (poses from DDS, no id column filled) reads as id 1 where it has a box."""
    path = tmp_path / 'poses.csv'
    with path.open('w', newline='') as handle:
        table = csv.writer(handle)
        table.writerow(POSE_COLUMNS)
        for index, box in enumerate([BOX, None, BOX]):
            row = dict.fromkeys(POSE_COLUMNS, '')
            row.update(frame=index, stamp_ns=index, status='TRACKING' if box else 'NO_POSE')
            if box:
                row.update(zip(('box_x', 'box_y', 'box_w', 'box_h'), box, strict=True))
            table.writerow([row[c] for c in POSE_COLUMNS])
    assert read_ids(path) == {'': [1, 0, 1]}


def test_two_tracks_crossing_and_a_swap() -> None:
    """Two people for three frames; ids 1 and 2 follow them, then swap on the last frame:
    two switches, MOTA 1 - 2 / 6; IDF1 maps each person to their first id: 4 of 6 true,
    2 missed, 2 false: 2 * 4 / (2 * 4 + 2 + 2) = 2 / 3. A frame with no person in view does not
    count, though a target is reported on it."""
    left, right = BOX, (300.0, 100.0, 40.0, 40.0)
    truth = {'person_1/head': [left, left, left, None], 'person_2/head': [right, right, right, None]}
    reported = [{1: left, 2: right}, {1: left, 2: right}, {2: left, 1: right}, {1: left}]
    scores = identity_scores(truth, reported)
    assert scores == {'mota': round(1 - 2 / 6, 4), 'idf1': round(2 / 3, 4), 'id_switches': 2}


def test_a_box_matches_only_a_track_of_its_kind() -> None:
    """A hand on a face is no head: with the kinds given, the head track is missed and the hand
    a false positive; without them the hand's box would count as the head."""
    truth = {'person_1/head': [(0.0, 0.0, 10.0, 10.0)] * 4}
    reported = [{2: (1.0, 1.0, 10.0, 10.0)}] * 4
    assert identity_scores(truth, reported)['idf1'] == 1.0
    scores = identity_scores(truth, reported, kinds={2: 'hand'})
    assert scores['idf1'] == 0.0 and scores['mota'] == -1.0
    assert identity_scores(truth, reported, kinds={2: 'head'})['idf1'] == 1.0


@pytest.mark.skipif(not all((REAL_DATA / name).is_dir() for name in REAL_PAIR), reason='real sequences absent')
def test_two_real_people_side_by_side(tmp_path) -> None:
    """Each sequence scaled to 240 px high, trimmed to the shorter; each truth moved with its frame."""
    bag = side_by_side(*(REAL_DATA / name for name in REAL_PAIR), tmp_path / 'pair')
    frames = list(open_sequence(bag))
    left, right = (list(open_sequence(REAL_DATA / name)) for name in REAL_PAIR)
    assert len(frames) == min(len(left), len(right))
    first = frames[0]
    assert first.image.shape[0] == 240
    k = 240 / left[0].image.shape[0]
    assert first.ground_truths['person_1/head'] == pytest.approx(tuple(v * k for v in left[0].ground_truth))
    k = 240 / right[0].image.shape[0]
    x, *rest = right[0].ground_truth
    offset = round(left[0].image.shape[1] * 240 / left[0].image.shape[0])
    expected = (x * k + offset, *(v * k for v in rest))
    assert first.ground_truths['person_2/head'] == pytest.approx(expected)


@pytest.mark.skipif(not all((REAL_DATA / name).is_dir() for name in REAL_PAIR), reason='real sequences absent')
def test_two_real_people_side_by_side_are_both_followed(tmp_path) -> None:
    """The pair as people (``--max-people 2``), from nothing: the left face is 21 working
    pixels, under the 40 px the whole-frame search finds. A later person is taken up only on
    a face, so their head also looks for smaller ones: both heads are followed under one id
    each (the left one was never found: IDF1 0.66)."""
    bag = side_by_side(*(REAL_DATA / name for name in REAL_PAIR), tmp_path / 'pair')
    options = TrackOptions(target='person', max_people=2, video=False, progress=False)
    summary = track_sequence(bag, tmp_path / 'run', options)
    print(summary['tracks'], summary['all_tracks'])
    assert all(track['precision_20px'] >= 0.9 for track in summary['tracks'].values())
    assert summary['all_tracks']['id_switches'] == 0 and summary['all_tracks']['idf1'] >= 0.9
