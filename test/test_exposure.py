"""Exposure normalisation: hand-computed gains."""

from __future__ import annotations

import numpy as np

from human_tracker.vision.cues.exposure import MAX_EXPOSURE_GAIN, normalise_exposure


def test_a_dark_frame_is_brightened_until_its_brightest_reach_white() -> None:
    # Every value 100: the 99th percentile is 100, the gain 2.55, so 100 becomes 255.
    frame = np.full((40, 40, 3), 100, dtype=np.uint8)
    assert (normalise_exposure(frame) == 255).all()
    # Values 0..99 (a grey ramp): the 99th percentile of the sampled pixels sets the gain.
    ramp = np.tile(np.arange(100, dtype=np.uint8), (40, 1))
    sampled = ramp[::4, ::4]
    gain = 255.0 / np.percentile(sampled, 99.0)
    np.testing.assert_array_equal(normalise_exposure(ramp), np.clip(np.rint(ramp * gain), 0, 255).astype(np.uint8))


def test_the_gain_is_bounded_and_a_bright_frame_is_left_as_it_is() -> None:
    # Every value 20: 255 / 20 = 12.75, bounded to 4 (80).
    assert MAX_EXPOSURE_GAIN == 4.0
    assert (normalise_exposure(np.full((8, 8), 20, dtype=np.uint8)) == 80).all()
    assert (normalise_exposure(np.full((8, 8), 20, dtype=np.uint8), max_gain=2.0) == 40).all()
    # 255 / 210 = 1.21, under 1.25: the frame itself, not a copy.
    bright = np.full((8, 8), 210, dtype=np.uint8)
    assert normalise_exposure(bright) is bright
    dark = np.full((8, 8), 20, dtype=np.uint8)
    assert normalise_exposure(dark, max_gain=1.0) is dark
    # A blank frame stays blank.
    assert not normalise_exposure(np.zeros((8, 8), dtype=np.uint8)).any()
