"""Broken bags give a clear error and a non-zero exit from bag_play and the offline command."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest
from ros_harness import environment
from rosbags.rosbag2 import Writer

from human_tracker.io.bags import TYPESTORE


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


KINDS = ['empty_folder', 'missing_metadata', 'garbage_metadata', 'truncated', 'corrupted']


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
    bag = _make(kind, tmp_path, head_bag)
    result = subprocess.run(
        [sys.executable, '-m', 'human_tracker.ros.bag_play', str(bag), '--rate', '50'],
        capture_output=True,
        text=True,
        timeout=120,
        env=environment(),
    )
    assert result.returncode == 1, result.stderr
    assert 'bag_play: error:' in result.stderr and 'Traceback' not in result.stderr
