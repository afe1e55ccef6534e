"""A head's reported box found again by its grey-level look (:mod:`human_tracker.vision.faces.box_look`)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from human_tracker.vision.faces.box_look import BoxLook
from human_tracker.vision.track.parameters import TargetParameters

BOX = (60.0, 40.0, 30.0, 36.0)


def _texture(seed: int) -> np.ndarray:
    noise = np.random.default_rng(seed).integers(0, 256, (120, 160)).astype(np.uint8)
    return cv2.GaussianBlur(noise, (0, 0), 2.0)


def _learnt(grey: np.ndarray, box: tuple[float, float, float, float] = BOX) -> BoxLook:
    look = BoxLook()
    look.learn(grey, box)
    return look


def test_the_look_is_found_where_it_moved_within_the_reach() -> None:
    grey = _texture(0)
    moved = np.roll(grey, (4, -6), axis=(0, 1))  # 4 px down, 6 px left
    assert _learnt(grey).find(moved, BOX, reach=0.35, min_match=0.6) == (54.0, 44.0, 30.0, 36.0)


def test_a_look_moved_beyond_the_reach_or_gone_moves_no_box() -> None:
    grey = _texture(0)
    look = _learnt(grey)
    assert look.find(np.roll(grey, 20, axis=1), BOX, reach=0.35, min_match=0.6) is None  # 20 px > 0.35 x 30
    assert look.find(_texture(1), BOX, reach=0.35, min_match=0.6) is None


def test_a_search_window_leaving_the_frame_moves_no_box() -> None:
    grey = _texture(0)
    near_edge = (2.0, 40.0, 30.0, 36.0)
    assert _learnt(grey, near_edge).find(grey, near_edge, reach=0.35, min_match=0.6) is None


def test_no_look_is_learnt_from_a_box_too_small_or_outside_the_frame() -> None:
    grey = _texture(0)
    assert _learnt(grey, (60.0, 40.0, 6.0, 8.0)).patch is None
    assert _learnt(grey, (150.0, 40.0, 30.0, 36.0)).patch is None
    assert BoxLook().find(grey, BOX, reach=0.35, min_match=0.6) is None


def test_a_look_learnt_at_one_size_is_found_at_another() -> None:
    grey = _texture(0)
    look = _learnt(grey)
    larger = cv2.resize(grey, None, fx=1.2, fy=1.2, interpolation=cv2.INTER_LINEAR)
    x, y, w, h = (1.2 * v for v in BOX)
    found = look.find(larger, (x + 3.0, y - 2.0, w, h), reach=0.35, min_match=0.6)
    assert found is not None
    assert abs(found[0] - x) <= 1.0 and abs(found[1] - y) <= 1.0


@pytest.mark.parametrize(
    ('name', 'value'),
    [('box_search_reach', -0.1), ('box_search_reach', 3.0), ('box_min_match', 1.5), ('box_look_rate', 1.5)],
)
def test_a_box_search_out_of_range_is_refused(name: str, value: float) -> None:
    with pytest.raises(ValueError, match=name):
        TargetParameters(**{name: value}).validate()


def test_a_look_is_found_at_its_own_size_around_a_box_too_small() -> None:
    # A contour shrunk onto the features inside a face carries a box a third of the face's size.
    grey = _texture(0)
    small = (69.0, 50.0, 10.0, 12.0)
    found = _learnt(grey).find(grey, small, reach=0.35, min_match=0.6)
    assert found is not None
    assert np.allclose(found, BOX, atol=1.0)


def test_a_matched_look_is_blended_into_the_look_at_its_rate() -> None:
    before, after = _texture(0), _texture(1)
    look = _learnt(before)
    look.learn(after, BOX, rate=0.25)
    x, y, w, h = (round(v) for v in BOX)
    expected = 0.75 * before[y : y + h, x : x + w] + 0.25 * after[y : y + h, x : x + w]
    assert look.patch is not None
    assert np.allclose(look.patch, expected, atol=1e-3)
    assert _learnt(before).find(after, BOX, reach=0.35, min_match=0.6) is None  # the old look alone: gone
