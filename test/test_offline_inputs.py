"""What the offline command says of awkward input: grey frames for a hand, a truncated video,
a sequence without ground truth, a start box at the image's edge, where its outputs go."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import BAGS, HEAD_BAG

from human_tracker.io.bags import read_frames
from human_tracker.io.sequences import open_sequence, sequence_name
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.filter.contour_filter import check_box_in_image

CLI = [sys.executable, '-m', 'human_tracker.cli']


def _frames(bag: Path, count: int) -> list[np.ndarray]:
    return [cv2.imdecode(f.message.data, cv2.IMREAD_COLOR) for f in list(read_frames(bag))[:count]]


def _statuses(out: Path) -> list[str]:
    with (out / 'poses.csv').open() as handle:
        return [row['status'] for row in csv.DictReader(handle)]


def test_a_hand_on_grey_frames_is_never_reported_tracked(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """The waving-hand bag in colour: the hand is followed. The same frames in grey: no skin,
    so no TRACKING hand, and the run says why once (log and summary)."""
    frames = _frames(BAGS / 'hand_wave', 60)
    colour, grey = tmp_path / 'colour', tmp_path / 'grey'
    for folder, convert in ((colour, lambda i: i), (grey, lambda i: cv2.cvtColor(i, cv2.COLOR_BGR2GRAY))):
        folder.mkdir()
        for index, image in enumerate(frames):
            cv2.imwrite(str(folder / f'{index:04d}.png'), convert(image))
    options = TrackOptions(target='hand', progress=False, video=False)
    track_sequence(colour, tmp_path / 'out_colour', options)
    assert _statuses(tmp_path / 'out_colour').count('TRACKING') >= 30  # the test can fail: colour finds the hand
    summary = track_sequence(grey, tmp_path / 'out_grey', options)
    assert 'TRACKING' not in _statuses(tmp_path / 'out_grey')
    assert summary['frames_without_colour'] == 60 and summary['frames_tracked'] == 0
    said = [r.getMessage() for r in caplog.records if 'no colour' in r.getMessage()]
    assert len(said) == 1 and said == summary['warnings'], said
    # A person on the same grey frames: the head may be followed, the hand is not.
    person = track_sequence(grey, tmp_path / 'out_person', TrackOptions(target='person', progress=False, video=False))
    with (tmp_path / 'out_person' / 'poses.csv').open() as handle:
        hands = [row['status'] for row in csv.DictReader(handle) if row['kind'] == 'hand']
    assert hands and 'TRACKING' not in hands and person['warnings']


def test_a_truncated_video_is_read_to_its_end_with_a_warning(tmp_path: Path) -> None:
    path = tmp_path / 'clip.avi'
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*'MJPG'), 30.0, (640, 480))
    for image in _frames(HEAD_BAG, 30):
        writer.write(image)
    writer.release()
    assert open_sequence(path).length == 30
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])  # cut in the middle: the header still announces 30
    result = subprocess.run(
        [*CLI, 'track', str(path), '--no-video', '--quiet', '--out', str(tmp_path / 'out')],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / 'out' / 'summary.json').read_text())
    read = summary['frames']
    assert 0 < read < 30
    message = f'{read} frames read of the 30 its header announces'
    assert message in result.stderr and any(message in w for w in summary['warnings']), result.stderr


def test_eval_against_a_sequence_without_ground_truth_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / 'walk'
    folder.mkdir()
    for index, image in enumerate(_frames(HEAD_BAG, 5)):
        cv2.imwrite(str(folder / f'{index:04d}.jpg'), image)
    out = tmp_path / 'out'
    track_sequence(folder, out, TrackOptions(progress=False, video=False))
    result = subprocess.run([*CLI, 'eval', str(out / 'poses.csv'), str(folder)], capture_output=True, text=True)
    assert result.returncode == 2 and 'no ground truth in' in result.stderr, result.stdout + result.stderr
    assert 'NaN' not in result.stdout


def test_the_default_output_folder_is_named_after_the_sequence(tmp_path: Path) -> None:
    """``.../david/img`` and ``.../trellis/img`` no longer write to the same ``out/track/img``."""
    for name in ('first', 'second'):
        (tmp_path / name / 'img').mkdir(parents=True)
        for index, image in enumerate(_frames(HEAD_BAG, 3)):
            cv2.imwrite(str(tmp_path / name / 'img' / f'{index:04d}.jpg'), image)
        assert sequence_name(tmp_path / name / 'img') == name
        result = subprocess.run(
            [*CLI, 'track', str(tmp_path / name / 'img'), '--no-video', '--quiet'],
            capture_output=True,
            text=True,
            cwd=tmp_path,
        )
        assert result.returncode == 0, result.stderr
        assert (tmp_path / 'out' / 'track' / name / 'poses.csv').exists()
    assert sequence_name(HEAD_BAG) == 'head_basic' and sequence_name(HEAD_BAG / 'head_basic.mcap') == 'head_basic'


def test_the_progress_bar_knows_how_many_frames_come() -> None:
    assert open_sequence(HEAD_BAG).length == 120


def test_a_start_box_at_the_edge_is_taken_and_one_outside_says_where() -> None:
    check_box_in_image((590, 100, 80, 60), (480, 640))  # partly outside, centre inside: taken
    with pytest.raises(ValueError, match=r'centre \(650, 130\) right of x=640: outside the 640x480 image \(part'):
        check_box_in_image((610, 100, 80, 60), (480, 640))
    with pytest.raises(ValueError, match=r'above y=0: outside the 640x480 image \(no part of the box is in it\)'):
        check_box_in_image((100, -200, 80, 60), (480, 640))


def test_track_help_explains_every_option() -> None:
    result = subprocess.run([*CLI, 'track', '--help'], capture_output=True, text=True)
    assert result.returncode == 0
    text = ' '.join(result.stdout.split())
    assert 'particles of each target' in text and 'seed of the random generators' in text
