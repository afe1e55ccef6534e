"""The working resolution: cues computed on reduced frames, results in the camera's pixels."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import REPO

from human_tracker.evaluation.metrics import summarise
from human_tracker.io.images import to_mono8
from human_tracker.io.sequences import open_sequence
from human_tracker.vision.cues.background import BackgroundModel
from human_tracker.vision.cues.evidence import at_working
from human_tracker.vision.cues.resolution import same_frame, to_working, working_scale, working_shape
from human_tracker.vision.cues.skin import SkinParameters
from human_tracker.vision.filter.contour_filter import TrackerParameters, state_from_box
from human_tracker.vision.filter.templates import head_and_shoulders
from human_tracker.vision.track.target import TargetParameters, TargetTracker


def test_frames_wider_than_the_working_width_are_reduced_to_it() -> None:
    assert working_scale(640, 320) == 0.5
    assert working_scale(320, 320) == working_scale(200, 320) == working_scale(640, 0) == 1.0
    assert working_shape((480, 640, 3), 320) == (240, 320)
    assert working_shape((360, 480), 320) == (240, 320)
    frame = np.zeros((480, 640, 3), np.uint8)
    frame[100:102, 200:202] = 200  # a 2x2 block averages into one working pixel
    reduced = to_working(frame, 320)
    assert reduced.shape == (240, 320, 3) and reduced[50, 100, 0] == 200
    small = np.zeros((120, 160), np.uint8)
    assert to_working(small, 320) is small
    labels = np.zeros((480, 640), np.uint8)
    labels[::2, ::2] = 255  # nearest neighbour keeps labels binary
    assert set(np.unique(to_working(labels, 320, mask=True))) <= {0, 255}


def test_a_boolean_mask_is_reduced_by_nearest_neighbour_and_stays_boolean() -> None:
    """OpenCV 4.6 (a robot's) refuses boolean arrays; the reduction takes every other pixel."""
    mask = np.zeros((480, 640), dtype=bool)
    mask[100:200, 300:400] = True
    reduced = to_working(mask, 320, mask=True)
    assert reduced.dtype == bool and reduced.shape == (240, 320)
    np.testing.assert_array_equal(reduced, mask[::2, ::2])


def test_lengths_in_pixels_scale_with_the_image() -> None:
    filter_parameters = TrackerParameters().scaled(0.5)
    assert filter_parameters.search_halfwidth == 6.0 and filter_parameters.min_scale == 12.0
    # ρ and the costs are squared distances, K their inverse: the same likelihood.
    assert filter_parameters.miss_penalty == 36.0 and filter_parameters.likelihood_gain == pytest.approx(0.04)
    assert filter_parameters.process_noise == (2.5, 2.5, 0.01, 0.02)
    assert filter_parameters.initial_spread == (4.0, 4.0, 0.08, 0.08)
    target = TargetParameters().scaled(0.5)
    assert (target.min_blob_area, target.region_closing, target.edge_blur_sigma) == (250, 2, 0.75)
    skin = SkinParameters().scaled(0.5)
    assert (skin.cell_size, skin.min_cluster_pixels) == (4, 4)
    assert TrackerParameters().scaled(1.0) == TrackerParameters()


def test_target_parameters_are_scaled_once_per_scale() -> None:
    """A track asks for its parameters at its scale several times a frame: one object per
    scale, and a copy with another value is scaled afresh."""
    parameters = TargetParameters()
    assert parameters.scaled(0.5) is parameters.scaled(0.5)
    assert parameters.scaled(0.25).edge_blur_sigma == 0.375
    changed = replace(parameters, edge_blur_sigma=3.0)
    assert changed.scaled(0.5).edge_blur_sigma == 1.5 and parameters.scaled(0.5).edge_blur_sigma == 0.75
    assert changed != parameters and replace(changed, edge_blur_sigma=1.5) == parameters


def _run(working_width: int, mask_at_working_size: bool) -> tuple[dict, list]:
    """head_basic from its first box, background cue; returns the summary and the last particles."""
    frames = list(open_sequence(REPO / 'bags' / 'head_basic'))
    tracker = TargetTracker(head_and_shoulders(), TrackerParameters(), TargetParameters(working_width=working_width))
    tracker.initialise_from_box(frames[0].ground_truth)
    background = BackgroundModel()
    boxes, estimates = [], []
    for frame in frames:
        gray = to_mono8(frame.image)
        motion = background.apply(to_working(gray, working_width))
        if not mask_at_working_size:
            motion = np.kron(motion, np.ones((2, 2), np.uint8)) if working_width else motion
        result = tracker.process(frame.image, motion)
        boxes.append(result.estimate.box if result.tracking else None)
        estimates.append(result.estimate)
    particles = tracker.particles
    assert particles is not None
    # The cloud and the estimate are in the camera's pixels, wherever the filter works.
    assert np.linalg.norm(particles[:, :2].mean(axis=0) - estimates[-1].state[:2]) < 10
    return summarise(boxes, [f.ground_truth for f in frames]), estimates


def test_tracking_at_half_size_reports_camera_pixels_and_matches_full_size() -> None:
    full, full_estimates = _run(0, True)
    half, half_estimates = _run(320, True)
    print(f'head_basic, 640x480 frames: full size {full}; working width 320 {half}')
    assert full['precision_20px'] >= 0.95 and half['precision_20px'] >= 0.95
    # Same target, same place, same size (scale s in camera pixels per template unit).
    last_full, last_half = full_estimates[-1].state, half_estimates[-1].state
    assert abs(last_full[2] - last_half[2]) < 0.15 * last_full[2]
    assert np.hypot(*(last_full[:2] - last_half[:2])) < 10


def test_masks_may_come_at_any_resolution_of_the_frame() -> None:
    working, _ = _run(320, True)
    camera, _ = _run(320, False)
    assert working == camera  # a full-size mask is reduced to exactly the working one
    assert same_frame((240, 320), (480, 640)) and same_frame((121, 160), (480, 640))
    assert not same_frame((100, 100), (480, 640)) and not same_frame((0, 0), (480, 640))
    tracker = TargetTracker(head_and_shoulders())
    frame = np.zeros((480, 640), np.uint8)
    with pytest.raises(ValueError, match='any resolution'):
        tracker.process(frame, np.zeros((100, 100), np.uint8))
    # A cue stage at another working width (here 160): its mask is brought to the tracker's.
    moving = np.zeros((120, 160), np.uint8)
    moving[30:60, 70:90] = 255
    working = at_working('mask', moving, (480, 640), tracker.working_width(640))
    assert working.shape == (240, 320)
    assert np.count_nonzero(working) == 4 * np.count_nonzero(moving)


def test_the_filter_follows_a_change_of_frame_size() -> None:
    """A box given before the first frame, then the camera switches resolution."""
    tracker = TargetTracker(head_and_shoulders())
    tracker.initialise_from_box((280, 151, 80, 100))
    before = tracker.particles.copy()
    tracker.process(np.zeros((480, 640), np.uint8))
    assert tracker.scale == 0.5
    tracker.process(np.zeros((240, 320), np.uint8))
    assert tracker.scale == 1.0
    # Two prediction steps later the cloud is still where the box was, in camera pixels.
    assert np.linalg.norm(tracker.particles[:, :2].mean(axis=0) - before[:, :2].mean(axis=0)) < 15


def test_a_small_target_is_tracked_on_a_less_reduced_frame() -> None:
    """A head box 30 pixels wide in 640x480 frames would be 15 working pixels across at 320:
    below `min_target_width` (20), so the track works on a wider frame, with the margin."""
    frame = np.zeros((480, 640), np.uint8)
    large = TargetTracker(head_and_shoulders())
    large.initialise_from_box((280, 151, 80, 100))
    large.process(frame)
    assert large.scale == 0.5 and large.working_width(640) == 320
    small = TargetTracker(head_and_shoulders())
    small.initialise_from_box((300, 200, 30, 40))
    s = state_from_box((300, 200, 30, 40), head_and_shoulders())[2]
    width = small.working_width(640)
    assert width == int(np.ceil(1.25 * 20.0 / s * 640)) and 320 < width < 640
    small.process(frame)
    assert small.scale == width / 640
    # The cloud stays in camera pixels where the box was.
    assert np.linalg.norm(small.particles[:, :2].mean(axis=0) - (315, 220)) < 15
    # Beyond the camera's own pixels the frame is not enlarged; 0 turns the rule off; a
    # forgotten target's successor starts on the usual frame.
    tiny = TargetTracker(head_and_shoulders())
    tiny.initialise_from_box((300, 200, 8, 10))
    assert tiny.working_width(640) == 0
    off = TargetTracker(head_and_shoulders(), parameters=TargetParameters(min_target_width=0.0))
    off.initialise_from_box((300, 200, 30, 40))
    assert off.working_width(640) == 320
    small.reset()
    assert small.working_width(640) == 320
    with pytest.raises(ValueError, match='min_target_width'):
        TargetParameters(min_target_width=-1.0).validate()
