"""Measurement model (eqs. 1-4) with hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from human_tracker.vision.cues.edges import _strongest_channel, edge_map
from human_tracker.vision.filter.measurement import (
    _pixel,
    colour_costs,
    contour_costs,
    log_likelihood,
    normalised_weights,
)

VERTICAL_EDGE = 1  # 1 + orientation 0°: the gradient of a vertical edge points along x


def _scene() -> np.ndarray:
    """A 40x40 edge map with a vertical edge line at column 13."""
    edges = np.zeros((40, 40), dtype=np.uint8)
    edges[:, 13] = VERTICAL_EDGE
    return edges


POINTS = np.array([[0.0, 0.0], [0.0, 5.0]])
NORMALS = np.array([[1.0, 0.0], [0.0, 1.0]])  # first point looks along x, second along y


def test_eq2_distance_squared_or_miss_penalty() -> None:
    # Particle at (10, 10), s = 1, θ = 0. Point 0 at (10, 10) finds the edge 3 px away along
    # its normal: φ = 3² = 9. Point 1 at (10, 15) looks along y and never meets column 13: φ = ρ.
    particles = np.array([[10.0, 10.0, 1.0, 0.0]])
    costs, matched, _, squared_distances, _ = contour_costs(
        _scene(), particles, POINTS, NORMALS, search_halfwidth=5, miss_penalty=50
    )
    assert costs[0] == pytest.approx(9 + 50) and matched[0] == 1
    assert squared_distances[0] == pytest.approx(9)  # the matched point's d² only, not the miss
    # With δ = 3 the edge at d = 3 is no longer within d < δ: both points miss.
    costs, matched, _, _, _ = contour_costs(_scene(), particles, POINTS, NORMALS, search_halfwidth=3, miss_penalty=50)
    assert costs[0] == pytest.approx(100) and matched[0] == 0


def test_a_contour_smaller_than_the_reference_scale_is_measured_in_its_own_size() -> None:
    # s = 1 against s_ref = 2: δ = 8 searches 4 px, and the edge 3 px away counts (3 / 0.5)² = 36;
    # δ = 5 searches 2.5 px and misses it. Σ d² stays in pixels. At s >= s_ref: eq. 2 as it is.
    particles = np.array([[10.0, 10.0, 1.0, 0.0]])
    costs, matched, _, squared_distances, _ = contour_costs(
        _scene(), particles, POINTS, NORMALS, search_halfwidth=8, miss_penalty=50, reference_scale=2.0
    )
    assert costs[0] == pytest.approx(36 + 50) and matched[0] == 1 and squared_distances[0] == pytest.approx(9)
    costs, matched, _, _, _ = contour_costs(
        _scene(), particles, POINTS, NORMALS, search_halfwidth=5, miss_penalty=50, reference_scale=2.0
    )
    assert costs[0] == pytest.approx(100) and matched[0] == 0
    for reference in (0.0, 1.0, 0.5):
        costs, _, _, _, _ = contour_costs(
            _scene(), particles, POINTS, NORMALS, search_halfwidth=5, miss_penalty=50, reference_scale=reference
        )
        assert costs[0] == pytest.approx(9 + 50)


def test_eq2_searches_both_sides_and_takes_the_closest_edge() -> None:
    edges = _scene()
    edges[:, 8] = VERTICAL_EDGE  # 2 px on the other side of x = 10: closer than column 13
    particles = np.array([[10.0, 10.0, 1.0, 0.0]])
    costs, _, _, _, _ = contour_costs(edges, particles, POINTS[:1], NORMALS[:1], search_halfwidth=5, miss_penalty=50)
    assert costs[0] == pytest.approx(4)


def test_probes_round_to_the_pixel_as_floor_does() -> None:
    # A probe's pixel is floor(x + 0.5), halves up, inside the image and past its edges (a
    # particle's probes may leave it); the kernels get it by truncation after a shift.
    coordinates = np.concatenate([np.arange(-40.0, 40.0, 0.25), np.random.default_rng(0).uniform(-3000, 3000, 2000)])
    assert [_pixel(c) for c in coordinates] == [int(np.floor(c + 0.5)) for c in coordinates]


def test_state_moves_the_points_scale_and_rotation_apply() -> None:
    # θ = -90° maps template point (0, 5) to (5, 0) and its normal from +y to +x; s = 2 makes
    # the offset (10, 0), so from (0, 10) the point lands on (10, 10) and meets column 13 at d = 3.
    particles = np.array([[0.0, 10.0, 2.0, -np.pi / 2]])
    fit = contour_costs(_scene(), particles, POINTS[1:], NORMALS[1:], search_halfwidth=5, miss_penalty=50)
    costs, matched = fit.costs, fit.matched
    assert matched[0] == 1 and costs[0] == pytest.approx(9)


def test_each_particle_is_measured_in_its_own_shape() -> None:
    # Two shapes of one point each: shape 0 looks along x from (0, 0) and finds column 13 at
    # d = 3 from (10, 10); shape 1 sits 2 px further right and finds it at d = 1.
    points = np.array([[[0.0, 0.0]], [[2.0, 0.0]]])
    normals = np.array([[[1.0, 0.0]], [[1.0, 0.0]]])
    particles = np.array([[10.0, 10.0, 1.0, 0.0]] * 3)
    fit = contour_costs(
        _scene(), particles, points, normals, search_halfwidth=5, miss_penalty=50, labels=np.array([0, 1, 0])
    )
    np.testing.assert_allclose(fit.costs, [9, 1, 9])
    # At s = 10 shape 0's point is (10, 10), with skin inside (x = 9, 8, 7) and none outside:
    # γ = 0; shape 1's is (30, 10), no skin on either side: γ = (3 / w) / 3 with w = 2.
    skin = np.zeros((40, 40), np.uint8)
    skin[:, :11] = 255
    colour, _ = colour_costs(skin, particles * [1, 1, 10, 1], points, normals, depth=0.3, labels=np.array([0, 1, 0]))
    np.testing.assert_allclose(colour, [0, 1 / 2, 0])
    with pytest.raises(ValueError, match='indices of the 2 shapes'):
        contour_costs(_scene(), particles, points, normals, search_halfwidth=5, miss_penalty=50, labels=[0, 2, 0])


def test_eq3_eq4_motion_weighting() -> None:
    particles = np.array([[10.0, 10.0, 1.0, 0.0]])
    motion = np.zeros((40, 40), dtype=np.uint8)
    still, _, moving_count, _, _ = contour_costs(
        _scene(), particles, POINTS, NORMALS, search_halfwidth=5, miss_penalty=50, motion=motion
    )
    # γ = 1 at a still edge: φ = 9 + ρ; the miss costs 2ρ: 59 + 100.
    assert still[0] == pytest.approx(9 + 50 + 100) and moving_count[0] == 0
    motion[:, 13] = 255
    moving, _, moving_count, _, _ = contour_costs(
        _scene(), particles, POINTS, NORMALS, search_halfwidth=5, miss_penalty=50, motion=motion
    )
    # γ = 0 at a moving edge: φ = 9; the miss still costs 2ρ.
    assert moving[0] == pytest.approx(9 + 100) and moving_count[0] == 1


def test_orientation_tolerance_rejects_edges_across_the_normal() -> None:
    edges = np.zeros((40, 40), dtype=np.uint8)
    edges[13, :] = 1 + 90  # a horizontal edge: gradient along y
    particles = np.array([[10.0, 10.0, 1.0, 0.0]])
    point, along_x = POINTS[:1], NORMALS[:1]
    strict, _, _, _, _ = contour_costs(
        edges, particles, point, along_x, search_halfwidth=5, miss_penalty=50, orientation_tolerance=0.5
    )
    assert strict[0] == pytest.approx(50)  # the only edge runs along the normal: no match
    along_y = np.array([[0.0, 1.0]])
    hit, _, _, _, _ = contour_costs(
        edges, particles, point, along_y, search_halfwidth=5, miss_penalty=50, orientation_tolerance=0.5
    )
    assert hit[0] == pytest.approx(9)
    paper, _, _, _, _ = contour_costs(edges, particles, point, along_y, search_halfwidth=5, miss_penalty=50)
    assert paper[0] == pytest.approx(9)


def test_colour_term_by_hand() -> None:
    # One point at (10, 10) looking along +x; depth 0.3 at s = 10 with 3 samples: interior
    # samples at x = 9, 8, 7, exterior ones at x = 11, 12, 13.
    particles = np.array([[10.0, 10.0, 10.0, 0.0]])
    point, normal = POINTS[:1], NORMALS[:1]
    skin = np.zeros((20, 20), dtype=np.uint8)
    skin[:, :12] = 255  # skin up to x = 11: interior all skin, one exterior sample on skin
    gamma, interior_skin = colour_costs(skin, particles, point, normal, interior_weight=2.0, depth=0.3, samples=3)
    assert gamma[0] == pytest.approx((0 / 2 + 1) / 3) and interior_skin[0] == pytest.approx(1.0)
    skin[:] = 0
    skin[:, :9] = 255  # skin up to x = 8: x = 9 inside is not skin, outside is clean
    gamma, interior_skin = colour_costs(skin, particles, point, normal, interior_weight=2.0, depth=0.3, samples=3)
    assert gamma[0] == pytest.approx((1 / 2 + 0) / 3) and interior_skin[0] == pytest.approx(2 / 3)
    # w > 1 is the paper's condition; the samples off the image count as not skin.
    with pytest.raises(ValueError, match='w'):
        colour_costs(skin, particles, point, normal, interior_weight=1.0)
    outside = colour_costs(skin, np.array([[-50.0, -50.0, 10.0, 0.0]]), point, normal, depth=0.3, samples=3)
    assert outside.costs[0] == pytest.approx((3 / 2) / 3) and outside.interior_skin[0] == 0.0


def test_colour_edges_see_a_step_between_equally_bright_colours() -> None:
    image = np.zeros((30, 30, 3), dtype=np.uint8)
    image[:, :15] = (0, 0, 200)  # red and blue halves of about the same intensity
    image[:, 15:] = (200, 0, 0)
    assert edge_map(image, blur_sigma=1.0).any()
    assert not edge_map(image.mean(axis=2).astype(np.uint8), blur_sigma=1.0).any()


def test_colour_edges_take_the_strongest_channel_by_hand() -> None:
    # |dx| + |dy| per channel: pixel 0: 3, 7, 5 -> channel 1; pixel 1: 4, 4, 1 -> the first
    # of equals, channel 0; pixel 2: 0, 0, 9 -> channel 2 (negative derivatives count by size).
    dx = np.array([[[1, -7, 2], [4, 0, 1], [0, 0, -9]]], dtype=np.int16)
    dy = np.array([[[-2, 0, 3], [0, -4, 0], [0, 0, 0]]], dtype=np.int16)
    strongest_x, strongest_y = _strongest_channel(dx, dy)
    np.testing.assert_array_equal(strongest_x, [[-7, 4, -9]])
    np.testing.assert_array_equal(strongest_y, [[0, 0, 0]])


def test_eq1_likelihood_and_weights() -> None:
    log_w = log_likelihood(np.array([10.0, 10.0 + np.log(2) / 0.5]), likelihood_gain=0.5)
    np.testing.assert_allclose(log_w, [-5.0, -5.0 - np.log(2)])
    np.testing.assert_allclose(normalised_weights(log_w), [2 / 3, 1 / 3])
    # Huge costs must not underflow to NaN.
    assert np.isfinite(normalised_weights(np.array([-1e6, -1e6 - 1]))).all()


def test_edge_map_marks_a_step_with_its_orientation() -> None:
    image = np.zeros((30, 30), dtype=np.uint8)
    image[:, 15:] = 200
    edges = edge_map(image, blur_sigma=1.0)
    columns = np.nonzero(edges.any(axis=0))[0]
    assert set(columns) <= {14, 15, 16} and len(columns) >= 1
    values = edges[edges > 0]
    assert np.all((values <= 3) | (values >= 178))  # orientation 0° (mod 180), stored as 1 + degrees


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(ValueError, match='δ'):
        contour_costs(_scene(), np.zeros((1, 4)), POINTS, NORMALS, search_halfwidth=0, miss_penalty=1)
    with pytest.raises(ValueError, match='motion mask'):
        contour_costs(
            _scene(),
            np.zeros((1, 4)),
            POINTS,
            NORMALS,
            search_halfwidth=2,
            miss_penalty=1,
            motion=np.zeros((3, 3), np.uint8),
        )
