"""Optical flow, the motion mask and rotation compensation (§2.4.2)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from human_tracker.vision.cues.optical_flow import (
    FLOW_METHODS,
    FlowParameters,
    OpticalFlow,
    dense_flow,
    motion_mask,
    rotation_flow,
)
from human_tracker.vision.geometry.camera import default_camera_matrix

K = np.array([[500.0, 0.0, 160.0], [0.0, 500.0, 120.0], [0.0, 0.0, 1.0]])


def _textured(seed: int = 0, shape: tuple[int, int] = (240, 320)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    coarse = rng.uniform(0, 255, size=(shape[0] // 8, shape[1] // 8)).astype(np.float32)
    return cv2.GaussianBlur(cv2.resize(coarse, shape[::-1], interpolation=cv2.INTER_CUBIC), (0, 0), 1.0).astype(
        np.uint8
    )


def test_rotation_flow_hand_computed() -> None:
    # At the principal point (x̄ = ȳ = 0): u = -fx ωy dt, v = fy ωx dt.
    flow = rotation_flow((240, 320), K, np.array([0.1, 0.2, 0.0]), 0.5)
    assert flow[120, 160].tolist() == pytest.approx([-500 * 0.2 * 0.5, 500 * 0.1 * 0.5])
    # Roll about the optical axis at x̄ = 1 (u = 660): u = fx ȳ ωz dt = 0, v = -fy x̄ ωz dt.
    roll = rotation_flow((240, 700), K, np.array([0.0, 0.0, 0.1]), 1.0)
    assert roll[120, 660].tolist() == pytest.approx([0.0, -50.0], abs=1e-4)


def test_compensation_removes_the_flow_of_a_known_rotation() -> None:
    """A pan of the camera (no moving object) is motion only until it is compensated."""
    omega, dt = np.array([0.0, 0.3, 0.0]), 1 / 30  # 0.01 rad per frame about the vertical
    rotation, _ = cv2.Rodrigues(omega * dt)
    homography = K @ rotation.T @ np.linalg.inv(K)  # static points as seen after the turn
    first = _textured()
    second = cv2.warpPerspective(first, homography, (320, 240), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    plain = OpticalFlow(FlowParameters(min_texture=0))
    plain.apply(first)
    _, uncompensated = plain.apply(second)
    compensated_flow = OpticalFlow(FlowParameters(min_texture=0))
    compensated_flow.apply(first)
    residual, compensated = compensated_flow.apply(second, camera_matrix=K, angular_velocity=omega, dt=dt)
    inner = (slice(30, -30), slice(30, -30))  # away from the warped border
    before, after = np.mean(uncompensated[inner] > 0), np.mean(compensated[inner] > 0)
    print(f'moving fraction: uncompensated {before:.3f}, compensated {after:.3f}')
    assert np.mean(uncompensated[inner] > 0) > 0.9  # a 5 px pan moves everything
    assert np.mean(compensated[inner] > 0) < 0.05
    assert np.median(np.hypot(*residual[inner].reshape(-1, 2).T)) < 0.3


@pytest.mark.parametrize('method', FLOW_METHODS)
def test_every_method_measures_a_translation(method: str) -> None:
    first = _textured(1)
    second = np.roll(first, 3, axis=1)  # 3 px to the right
    flow = dense_flow(first, second, method)
    inner = flow[40:-40, 40:-40].reshape(-1, 2)
    assert np.median(inner[:, 0]) == pytest.approx(3.0, abs=0.3)
    assert np.median(inner[:, 1]) == pytest.approx(0.0, abs=0.3)


def test_mask_marks_a_moving_square_and_ignores_noise_and_flat_regions() -> None:
    rng = np.random.default_rng(2)
    flat = np.full((120, 160), 120, dtype=np.uint8)
    square = _textured(3, (30, 30))
    flow = OpticalFlow()
    masks = []
    for x in (20, 26, 32):
        frame = flat.copy()
        frame[40:70, x : x + 30] = square
        noisy = np.clip(frame + rng.normal(0, 2.0, frame.shape), 0, 255).astype(np.uint8)
        masks.append(flow.apply(noisy)[1])
    assert masks[0].max() == 0  # first frame: nothing to compare with
    mask = masks[2]
    assert np.mean(mask[45:65, 37:57] > 0) > 0.8  # the square, where it is now
    assert np.mean(mask[:, 100:] > 0) == 0.0  # flat, noisy background: no invented motion


def test_motion_mask_thresholds_the_magnitude() -> None:
    flow = np.zeros((10, 10, 2), dtype=np.float32)
    flow[2:8, 2:8, 0] = 0.4
    assert motion_mask(flow, 0.5, median_size=0, opening_radius=0).max() == 0
    flow[2:8, 2:8, 0] = 0.6
    assert motion_mask(flow, 0.5, median_size=0, opening_radius=0)[2:8, 2:8].min() == 255


def test_bad_flow_parameters_are_refused() -> None:
    with pytest.raises(ValueError, match='method'):
        OpticalFlow(FlowParameters(method='magic'))
    with pytest.raises(ValueError, match='min_magnitude'):
        FlowParameters(min_magnitude=-1).validate()
    assert default_camera_matrix(320, 240)[0, 2] == 159.5
