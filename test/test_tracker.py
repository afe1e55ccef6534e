"""The contour tracker on the bundled bag, without ROS: accuracy and reproducibility."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from human_tracker.evaluation.metrics import summarise
from human_tracker.io.bags import read_frames
from human_tracker.ros.image_conversion import message_to_bgr8
from human_tracker.vision.cues.edges import edge_map
from human_tracker.vision.filter.contour_filter import RESIDUAL_FLOOR, ContourTracker, TrackerParameters
from human_tracker.vision.filter.templates import hand, head_and_shoulders, transform_points


def _track(bag, parameters: TrackerParameters) -> tuple[list, list, list]:
    tracker = ContourTracker(head_and_shoulders(), parameters)
    boxes, states, truth = [], [], []
    for frame in read_frames(bag):
        edges = edge_map(cv2.cvtColor(message_to_bgr8(frame.message), cv2.COLOR_BGR2GRAY))
        if not tracker.initialised:
            tracker.initialise_from_box(frame.ground_truth)
        estimate = tracker.step(edges)
        boxes.append(estimate.box)
        states.append(estimate.state)
        truth.append(frame.ground_truth)
    return boxes, states, truth


def test_tracks_the_head_on_the_bundled_bag(head_bag) -> None:
    boxes, _, truth = _track(head_bag, TrackerParameters())
    summary = summarise(boxes, truth)
    print(f'edge-only tracker on {head_bag.name}: {summary}')
    assert summary['precision_20px'] >= 0.9
    assert summary['mean_centre_error_px'] < 10


def test_same_seed_same_track(head_bag) -> None:
    _, first, _ = _track(head_bag, TrackerParameters(seed=5))
    _, again, _ = _track(head_bag, TrackerParameters(seed=5))
    np.testing.assert_array_equal(np.array(first), np.array(again))


def test_step_before_initialise_and_bad_parameters() -> None:
    tracker = ContourTracker(head_and_shoulders())
    with pytest.raises(RuntimeError, match='before initialise'):
        tracker.step(np.zeros((10, 10), np.uint8))
    for bad in (
        {'num_particles': 0},
        {'search_halfwidth': 0.0},
        {'search_reference_scale': -1.0},
        {'likelihood_gain': -1.0},
        {'velocity_damping': 2.0},
    ):
        with pytest.raises(ValueError, match=next(iter(bad))):
            ContourTracker(head_and_shoulders(), TrackerParameters(**bad))


def test_particle_count_changes_at_run_time() -> None:
    tracker = ContourTracker(head_and_shoulders(), TrackerParameters(num_particles=100))
    tracker.initialise(np.array([50.0, 50.0, 20.0, 0.0]))
    tracker.parameters.num_particles = 40
    tracker.step(np.zeros((100, 100), np.uint8))
    assert tracker.particles.shape == (40, 4)


def test_an_adaptive_filter_keeps_fewer_particles_when_locked_on(head_bag) -> None:
    """KLD-sampling between 100 and 500 particles: many at the start, where the cloud is spread,
    fewer once the cloud has gathered on the head; the head is followed as with 500."""
    tracker = ContourTracker(head_and_shoulders(), TrackerParameters(min_particles=100, kld_bin=(0.2, 0.2, 0.1, 0.2)))
    counts, boxes, truth = [], [], []
    for frame in list(read_frames(head_bag))[:40]:
        if not tracker.initialised:
            tracker.initialise_from_box(frame.ground_truth)
        estimate = tracker.step(edge_map(cv2.cvtColor(message_to_bgr8(frame.message), cv2.COLOR_BGR2GRAY)))
        counts.append(estimate.particle_count)
        boxes.append(estimate.box)
        truth.append(frame.ground_truth)
    print(f'particles: {counts}')
    assert counts[0] == 500 and 100 <= min(counts) and np.median(counts[10:]) < 400
    assert summarise(boxes, truth)['precision_20px'] >= 0.9


def test_fit_residual_is_the_rms_distance_to_the_edges_found() -> None:
    """A contour on a silhouette's own outline sits within a pixel or so of its edges, one
    shifted sideways by 4 px further off; with no edge at all the residual is δ. The position
    error is the residual above RESIDUAL_FLOOR, plus the pixel grid's 1/12 px², and with the
    cloud's spread makes the centre's covariance."""
    template = head_and_shoulders()
    state = np.array([80.0, 70.0, 40.0, 0.0])
    silhouette = np.zeros((160, 160), np.uint8)
    outline = (template.points * state[2] + state[:2]).round().astype(np.int32)
    cv2.fillPoly(silhouette, [outline], 255)
    estimates = []
    for shift in (0.0, 4.0):
        tracker = ContourTracker(
            template, TrackerParameters(num_particles=50, process_noise=(0.0,) * 4, initial_spread=(0.0,) * 4)
        )
        tracker.initialise(state + [shift, 0.0, 0.0, 0.0])
        estimates.append(tracker.step(edge_map(silhouette)))
    residuals = [e.fit_residual for e in estimates]
    assert residuals[0] < 1.5 < 2.0 < residuals[1] < 4.0
    for estimate in estimates:
        expected = np.sqrt(max(estimate.fit_residual**2 - RESIDUAL_FLOOR**2, 0.0) + 1 / 12)
        assert estimate.position_error == pytest.approx(expected)
        # All particles on one state: the centre's covariance is the position error alone.
        np.testing.assert_allclose(estimate.centre_covariance, estimate.position_error**2 * np.eye(2), atol=1e-9)
    assert estimates[0].position_error < 1.0 < 1.5 < estimates[1].position_error
    tracker = ContourTracker(template, TrackerParameters(num_particles=50))
    tracker.initialise(state)
    assert tracker.step(np.zeros((160, 160), np.uint8)).fit_residual == tracker.parameters.search_halfwidth


@pytest.mark.parametrize('shown', [0, 1])
def test_a_hand_is_followed_in_the_shape_it_shows(shown: int) -> None:
    """The mixed state: on an open hand's outline the particles settle in the open shape, on a
    fist's in the closed one (its 8ρ penalty notwithstanding), and the contour is drawn in it."""
    template = hand()
    state = np.array([80.0, 80.0, 60.0, 0.0])
    image = np.zeros((160, 160), np.uint8)
    outline = transform_points(template.shapes[shown].points, state)
    cv2.polylines(image, [np.round(outline).astype(np.int32)], False, 255, 2)
    tracker = ContourTracker(template, TrackerParameters(num_particles=200, process_noise=(1.0, 1.0, 0.01, 0.01)))
    tracker.initialise(state)
    assert set(tracker.labels.tolist()) == {0, 1}
    for _ in range(5):
        estimate = tracker.step(edge_map(image))
    assert estimate.shape == template.shapes[shown].name
    assert np.mean(tracker.labels == shown) > 0.7
    np.testing.assert_allclose(estimate.contour, transform_points(template.shapes[shown].points, estimate.state))
    # One shape draws no labels from the generator: a head's random stream is what it was.
    head = ContourTracker(head_and_shoulders(), TrackerParameters(num_particles=10))
    head.initialise(state)
    assert not head.labels.any()
