"""Scene generator and bag writing / reading (mcap and sqlite3)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from human_tracker.io.bags import BagError, read_frames, write_scene_bag
from human_tracker.scenes.generator import SCENES, render_scene

SMALL = dataclasses.replace(SCENES['head_basic'], name='small', width=160, height=120, head_width=24, num_frames=5)


def test_generator_is_deterministic_and_moves_the_person() -> None:
    first = list(render_scene(SMALL))
    again = list(render_scene(SMALL))
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a.image, b.image)
    assert first[0].box != first[-1].box
    other = list(render_scene(dataclasses.replace(SMALL, seed=99)))
    assert not np.array_equal(first[0].image, other[0].image)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
@pytest.mark.parametrize('compressed', [True, False])
def test_bag_round_trip(tmp_path, storage: str, compressed: bool) -> None:
    path = write_scene_bag(SMALL, tmp_path / 'bag', compressed=compressed, storage=storage)
    frames = list(read_frames(path))
    truth = list(render_scene(SMALL))
    assert [f.stamp_ns for f in frames] == [t.stamp_ns for t in truth]
    assert [f.ground_truth for f in frames] == [t.box for t in truth]
    assert hasattr(frames[0].message, 'format') == compressed


def test_bundled_head_bag_is_readable(head_bag) -> None:
    frames = list(read_frames(head_bag))
    assert len(frames) == SCENES['head_basic'].num_frames
    assert all(f.ground_truth is not None for f in frames)


def test_missing_bag_and_missing_topic_are_clear_errors(tmp_path, head_bag) -> None:
    with pytest.raises(BagError, match='cannot read bag'):
        list(read_frames(tmp_path / 'nothing'))
    with pytest.raises(BagError, match='no camera topic /nope'):
        list(read_frames(head_bag, camera_topic='/nope'))
