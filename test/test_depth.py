"""The target's distance from a registered depth image, hand-computed."""

from __future__ import annotations

import numpy as np

from human_tracker.vision.geometry.depth import MIN_READINGS, depth_image_to_metres, region_depth


def test_millimetres_and_metres_with_their_holes() -> None:
    metres = depth_image_to_metres(np.array([[0, 1500], [2000, 65535]], dtype=np.uint16))
    np.testing.assert_array_equal(metres, np.array([[np.nan, 1.5], [2.0, 65.535]], dtype=np.float32))
    floats = depth_image_to_metres(np.array([[np.nan, np.inf], [-1.0, 0.8]], dtype=np.float32))
    np.testing.assert_array_equal(np.isnan(floats), [[True, True], [True, False]])


def test_the_core_of_the_region_gives_the_median_and_its_robust_spread() -> None:
    """A 40x40 box at (20, 20) of a wall 3 m away: its core is the middle 20x20, where the face
    reads 1.0 m on the left half and 1.2 m on the right half, with holes; the wall outside the
    core does not count. Median 1.1 m; every reading is 0.1 m from it: spread 1.4826 * 0.1."""
    depth = np.full((100, 100), 3.0, dtype=np.float32)
    depth[30:50, 30:40], depth[30:50, 40:50] = 1.0, 1.2
    depth[30:34, 30:34] = np.nan  # holes: 16 readings fewer on each side
    depth[30:34, 46:50] = np.nan
    median, spread = region_depth(depth, (20.0, 20.0, 40.0, 40.0), (100, 100))
    assert abs(median - 1.1) < 1e-6
    assert abs(spread - 1.4826 * 0.1) < 1e-6
    # The same at half the resolution (a depth camera registered at another size).
    small = depth[::2, ::2]
    assert abs(region_depth(small, (20.0, 20.0, 40.0, 40.0), (100, 100))[0] - 1.1) < 1e-6


def test_too_few_readings_give_no_distance() -> None:
    """Readings only outside the core (the middle 50x50 of a 100x100 box) or too few in it."""
    depth = np.full((100, 100), np.nan, dtype=np.float32)
    depth[:, :25] = 2.0
    depth[50, 25 : 25 + MIN_READINGS - 1] = 1.0
    assert region_depth(depth, (0.0, 0.0, 100.0, 100.0), (100, 100)) is None
    depth[51, 25] = 1.0
    assert region_depth(depth, (0.0, 0.0, 100.0, 100.0), (100, 100)) == (1.0, 0.0)
