"""Broken bags give a clear error and a non-zero exit from bag_play and the offline command; a
recording cut short, or left without its metadata.yaml, replays what it holds, with a warning."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest
from conftest import REPO
from ros_harness import run_bag_play
from rosbags.rosbag2 import Writer

from human_tracker.io.bags import TYPESTORE, camera_frame_count, read_frames

BAGS = REPO / 'bags'


def _make(kind: str, root, head_bag):
    path = root / kind
    mcap = head_bag / 'head_basic.mcap'
    if kind == 'empty_folder':
        path.mkdir()
    elif kind == 'missing_metadata':
        path.mkdir()
        shutil.copy(mcap, path)
    elif kind == 'garbage_metadata':
        path.mkdir()
        (path / 'metadata.yaml').write_text('::: not a bag\n')
    elif kind in ('truncated', 'corrupted'):
        shutil.copytree(head_bag, path)
        data = bytearray((path / 'head_basic.mcap').read_bytes())
        if kind == 'truncated':
            data = data[: len(data) // 3]
        else:
            data[200_000:205_000] = bytes(5000)
        (path / 'head_basic.mcap').write_bytes(bytes(data))
    elif kind == 'no_camera_topic':
        with Writer(path, version=9) as writer:
            conn = writer.add_connection('/camera/image_raw', 'std_msgs/msg/String', typestore=TYPESTORE)
            writer.write(
                conn,
                1,
                TYPESTORE.serialize_cdr(
                    TYPESTORE.types['std_msgs/msg/String'](data='not an image'), 'std_msgs/msg/String'
                ),
            )
    return path


KINDS = ['empty_folder', 'garbage_metadata', 'corrupted']
# What a robot's recording stopped hard leaves: its file without metadata.yaml, or cut short.
RECOVERABLE = ['missing_metadata', 'truncated']


@pytest.mark.parametrize('kind', [*KINDS, 'no_camera_topic'])
def test_offline_command(kind: str, tmp_path, head_bag) -> None:
    bag = _make(kind, tmp_path, head_bag)
    result = subprocess.run(
        [
            sys.executable,
            '-m',
            'human_tracker.cli',
            'track',
            str(bag),
            '--quiet',
            '--no-video',
            '--out',
            str(tmp_path / 'out'),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    assert 'human_tracker track: error:' in result.stderr and 'Traceback' not in result.stderr


@pytest.mark.parametrize('kind', KINDS)
def test_bag_play(kind: str, tmp_path, head_bag) -> None:
    result = run_bag_play(str(_make(kind, tmp_path, head_bag)), '--rate', '50')
    assert result.returncode == 1, result.stderr
    assert 'bag_play: error:' in result.stderr and 'Traceback' not in result.stderr


@pytest.mark.parametrize('kind', RECOVERABLE)
def test_a_recording_stopped_hard_is_tracked_and_replayed(kind: str, tmp_path, head_bag) -> None:
    bag = _make(kind, tmp_path, head_bag)
    track = [sys.executable, '-m', 'human_tracker.cli', 'track', str(bag), '--quiet', '--no-video']
    result = subprocess.run([*track, '--out', str(tmp_path / 'out')], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / 'out' / 'summary.json').read_text())
    assert summary['frames'] >= (30 if kind == 'truncated' else 120)
    assert ('cut short' in ' '.join(summary['warnings'])) == (kind == 'truncated')
    played = run_bag_play(str(bag), '--rate', '50')
    assert played.returncode == 0, played.stderr
    assert ('cut short' in played.stderr) == (kind == 'truncated')


@pytest.mark.parametrize('name', sorted(p.name for p in BAGS.iterdir() if (p / 'metadata.yaml').exists()))
def test_each_bag_cut_at_half_gives_back_at_least_40_percent_of_its_frames(name: str, tmp_path) -> None:
    shutil.copytree(BAGS / name, tmp_path / name)
    (mcap,) = (tmp_path / name).glob('*.mcap')
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    said: list[str] = []
    frames = sum(1 for _ in read_frames(tmp_path / name, warn=said.append))
    whole = camera_frame_count(BAGS / name)
    print(f'{name}: {frames} of {whole} frames from the first half of the file; {said}')
    assert frames >= 0.4 * whole
    assert len(said) == 1 and 'cut short' in said[0]
