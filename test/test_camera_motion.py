"""The camera's own motion: recovered from a known shift, and compensated in the cues."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from human_tracker.vision.cues.background import BackgroundModel, BackgroundParameters
from human_tracker.vision.cues.camera_motion import CameraMotion, estimate_camera_motion, scale_transform
from human_tracker.vision.filter.contour_filter import ContourTracker, TrackerParameters
from human_tracker.vision.filter.dynamics import move_states
from human_tracker.vision.filter.templates import head_and_shoulders
from human_tracker.vision.track.target import TargetParameters, TargetTracker


def _scene(seed: int = 0, shape: tuple[int, int] = (240, 320)) -> np.ndarray:
    """A textured still scene: blurred noise, rich in corners."""
    noise = np.random.default_rng(seed).integers(0, 256, shape).astype(np.uint8)
    return cv2.GaussianBlur(noise, (0, 0), 2.0)


def _shifted(image: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """``image`` seen by a camera that moved so the scene shifts by (dx, dy) pixels."""
    transform = np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]])
    return cv2.warpAffine(image, transform, (image.shape[1], image.shape[0]), borderMode=cv2.BORDER_REFLECT)


def test_a_synthetic_shift_is_recovered() -> None:
    scene = _scene()
    transform = estimate_camera_motion(scene, _shifted(scene, 5.0, -3.0))
    assert transform is not None
    np.testing.assert_allclose(transform[:, 2], [5.0, -3.0], atol=0.1)
    np.testing.assert_allclose(transform[:, :2], np.eye(2), atol=0.005)


def test_a_rotation_and_zoom_are_recovered() -> None:
    scene = _scene(1)
    angle, zoom = 2.0, 1.03  # degrees, scale
    transform = cv2.getRotationMatrix2D((160.0, 120.0), angle, zoom)
    moved = cv2.warpAffine(scene, transform, (320, 240), borderMode=cv2.BORDER_REFLECT)
    found = estimate_camera_motion(scene, moved)
    assert found is not None
    assert np.hypot(found[0, 0], found[1, 0]) == pytest.approx(zoom, abs=0.005)
    # OpenCV's positive angle turns the image anticlockwise on screen: y points down.
    assert np.degrees(np.arctan2(found[1, 0], found[0, 0])) == pytest.approx(-angle, abs=0.1)


def test_a_still_camera_gives_the_identity_and_a_blank_frame_nothing() -> None:
    scene = _scene(2)
    np.testing.assert_array_equal(estimate_camera_motion(scene, scene.copy()), np.eye(2, 3))
    blank = np.full((240, 320), 128, np.uint8)
    assert estimate_camera_motion(blank, blank) is None
    with pytest.raises(ValueError, match='differ in size'):
        estimate_camera_motion(scene, scene[:100])


def test_a_moving_target_does_not_count_as_the_camera() -> None:
    """The scene shifts by (4, 0) while a textured block (the target) moves by (-10, 6)."""
    scene = _scene(3)
    block = _scene(4, (60, 60))
    before, after = scene.copy(), _shifted(scene, 4.0, 0.0)
    before[90:150, 130:190] = block
    after[96:156, 120:180] = block
    exclude = np.zeros_like(scene)
    exclude[80:170, 110:200] = 255
    for mask in (None, exclude):  # RANSAC alone already sets the block aside; the mask too
        transform = estimate_camera_motion(before, after, mask)
        assert transform is not None
        np.testing.assert_allclose(transform[:, 2], [4.0, 0.0], atol=0.2)


def test_a_stream_follows_its_corners_and_recovers_each_shift() -> None:
    """Over a stream the corners that fitted are followed on: on a still camera all of them
    are kept (no new detection), and a pan of (3, 1) px a frame is recovered from them."""
    scene = _scene(5)
    motion = CameraMotion()
    frames = [_shifted(scene, 3.0 * k, 1.0 * k) for k in range(4)]
    np.testing.assert_array_equal(motion.estimate(scene, scene.copy()), np.eye(2, 3))
    kept = motion.corners
    assert kept is not None and len(kept) >= motion.parameters.kept_share * motion.parameters.max_features
    for previous, current in zip(frames, frames[1:], strict=False):
        transform = motion.estimate(previous, current)
        assert transform is not None
        np.testing.assert_allclose(transform[:, 2], [3.0, 1.0], atol=0.1)
    # Corners on the excluded region are dropped before they are followed.
    exclude = np.full_like(scene, 255)
    assert motion.estimate(frames[-1], frames[-1].copy(), exclude) is None
    motion.reset()
    assert motion.corners is None


def test_states_move_with_the_camera() -> None:
    # Hand-computed: a quarter turn about the origin, zoom 2, then a shift of (10, 0).
    transform = np.array([[0.0, -2.0, 10.0], [2.0, 0.0, 0.0]])
    moved = move_states(np.array([[3.0, 1.0, 20.0, 0.1]]), transform)
    np.testing.assert_allclose(moved, [[10.0 - 2.0, 6.0, 40.0, 0.1 + np.pi / 2]])


def test_a_motion_measured_on_a_reduced_frame_scales_its_shift_only() -> None:
    transform = np.array([[0.8, -0.6, 3.0], [0.6, 0.8, -2.0]])
    np.testing.assert_allclose(scale_transform(transform, 2.0), [[0.8, -0.6, 6.0], [0.6, 0.8, -4.0]])
    assert transform[0, 2] == 3.0  # a copy


def test_the_tracker_is_carried_by_the_shake_and_leaves_the_pan_to_its_dynamics() -> None:
    """Hand-computed: a camera panning so the scene shifts 8 camera px a frame, handed to a
    tracker at half size (4 working px) with pan_smoothing 0.7: the running mean of the shift
    is 0.3 * 4 = 1.2, then 0.7 * 1.2 + 1.2 = 2.04, so the particles are carried by the rest,
    2.8 then 1.96 px; a still camera carries nothing."""
    image = cv2.cvtColor(cv2.resize(_scene(3), (640, 480)), cv2.COLOR_GRAY2BGR)
    parameters = TargetParameters(proposals='off', pan_smoothing=0.7)
    tracker = TargetTracker(head_and_shoulders(), TrackerParameters(), parameters)
    tracker.initialise_from_box((300.0, 200.0, 60.0, 70.0))
    pan = np.array([[1.0, 0.0, 8.0], [0.0, 1.0, 0.0]])
    carried = []
    for _ in range(2):
        tracker.process(image, camera_motion=pan)
        carried.append(tracker.camera.motion[:, 2])
    np.testing.assert_allclose(carried, [[2.8, 0.0], [1.96, 0.0]])
    still = TargetTracker(head_and_shoulders(), TrackerParameters(), TargetParameters(proposals='off'))
    still.initialise_from_box((300.0, 200.0, 60.0, 70.0))
    still.process(image, camera_motion=np.eye(2, 3))
    assert still.camera.motion is None


def test_the_filter_keeps_the_targets_own_velocity() -> None:
    """The camera pans so the scene shifts by -4 px a frame; a target still in the world was
    seen still in the last two frames' coordinates: carried, its velocity is the world's 0."""
    tracker = ContourTracker(head_and_shoulders(), TrackerParameters(num_particles=4))
    tracker.initialise(np.array([100.0, 80.0, 40.0, 0.0]))
    pan = np.array([[1.0, 0.0, -4.0], [0.0, 1.0, 0.0]])
    before = tracker.particles.copy()
    tracker.follow_camera(pan)
    np.testing.assert_allclose(tracker.particles[:, 0], before[:, 0] - 4.0)
    np.testing.assert_allclose(tracker.particles - tracker.previous, before - before)


def test_the_background_follows_the_camera() -> None:
    """A still scene seen by a camera that shifts 3 px a frame: compensated, it stays
    background; uncompensated, the shifted texture is foreground."""
    scene = _scene(5)
    frames = [_shifted(scene, 3.0 * k, 0.0) for k in range(6)]
    compensated, fixed = BackgroundModel(), BackgroundModel(BackgroundParameters(compensate_camera=False))
    for frame in frames:
        with_camera, without = compensated.apply(frame), fixed.apply(frame)
    assert np.count_nonzero(with_camera[:, 30:]) < 0.01 * with_camera[:, 30:].size
    assert np.count_nonzero(without) > 0.2 * without.size
    # The motion it measured, for the tracker: the shift of the last frame.
    np.testing.assert_allclose(compensated.camera_motion, [[1.0, 0.0, 3.0], [0.0, 1.0, 0.0]], atol=0.1)
    # In the pixels of the camera's frame, twice as wide.
    np.testing.assert_allclose(compensated.camera_motion_in(640), [[1.0, 0.0, 6.0], [0.0, 1.0, 0.0]], atol=0.2)
    assert fixed.camera_motion is None and fixed.camera_motion_in(640) is None
