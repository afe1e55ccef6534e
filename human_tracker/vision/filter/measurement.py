"""Measurement model of §2.3-2.4: how well a particle's contour fits the image edges.

For particle i and measurement point j, ``z(j)`` is the closest edge pixel on the spline
normal through ``x(j)``, searched up to ``search_halfwidth`` (δ) pixels on either side,
and ``d(j) = |x(j) - z(j)|``. Then

- eq. 2 (edges only):   φ(j) = d(j)²              if d(j) < δ, else ρ;
- eq. 3 (with motion):  φ(j) = d(j)² + ρ γ(z(j))  if d(j) < δ, else 2ρ,
  with eq. 4: γ(z) = 0 where the motion mask is set at z, 1 elsewhere;

and, with skin labels l (1 skin, 0 not; §3.2), the colour term

- γ_colour(j) = (1/w) mean_interior (1 - l) + mean_exterior l,

sampled along the normal through x(j) on the interior and exterior side of the contour,
with w = ``interior_weight`` > 1 (a hole in the skin labels inside costs less than skin
outside). The paper sums over the pixels of the interior and the exterior; sampling them
on the normals keeps the cost linear in the number of points, and the means make it
independent of how many samples there are. The tracker adds ρ γ_colour(j) to φ(j).

Eq. 1 weighs the particle by ``p(z | x) ∝ exp(-K Σ_j φ(j))``, K = ``likelihood_gain``.

One refinement over the paper: an edge pixel counts as ``z(j)`` only if its orientation is
within ``orientation_tolerance`` of the contour's tangent at ``x(j)``. A contour's own
edges run along it; without the test a shrunken contour finds clutter edges within δ for
every point and the filter collapses in scale. ``orientation_tolerance = π/2`` accepts any
edge, which is the paper's model exactly.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

__all__ = [
    'ColourFit',
    'ContourFit',
    'colour_costs',
    'contour_costs',
    'log_likelihood',
    'normalised_weights',
]


class ContourFit(NamedTuple):
    """How each particle's contour fits the image.

    Attributes:
        costs: ``(P,) float64`` Σ_j φ(j) of eq. 2 (or eq. 3 with motion).
        matched: ``(P,) int64`` points whose normal met an edge within δ.
        moving: ``(P,) int64`` of those, points whose edge lies on the motion mask.
        squared_distances: ``(P,) float64`` Σ d(j)² over the points that met an edge
            (pixels²): how far the contour sits from the edges it found.
        skin: ``(P,) float64`` share of the contour's interior samples labelled skin, or
            None without skin labels.
    """

    costs: np.ndarray
    matched: np.ndarray
    moving: np.ndarray
    squared_distances: np.ndarray
    skin: np.ndarray | None = None


class ColourFit(NamedTuple):
    """The colour term of every particle.

    Attributes:
        costs: ``(P,) float64`` Σ_j γ_colour(j).
        interior_skin: ``(P,) float64`` share of the interior samples labelled skin, in [0, 1].
    """

    costs: np.ndarray
    interior_skin: np.ndarray


# Added before truncating, so that truncation rounds down: cheaper than floor (with the walk
# below, the contour kernel of 500 particles 0.87 -> 0.79 ms, the same costs).
_ROUNDING_SHIFT = 1 << 20


@numba.njit(cache=True, fastmath=True, nogil=True, inline='always')
def _pixel(coordinate: float) -> int:
    """The index of the pixel ``coordinate`` (pixels) falls in, ``floor(coordinate + 0.5)``, for
    coordinates within ``_ROUNDING_SHIFT`` of the image."""
    return int(coordinate + (_ROUNDING_SHIFT + 0.5)) - _ROUNDING_SHIFT


@numba.njit(cache=True, fastmath=True, nogil=True, inline='always')
def _placed(
    x: float, y: float, scale: float, c: float, s: float, point: np.ndarray, normal: np.ndarray
) -> tuple[float, float, float, float]:
    """A template point and its unit normal in the image for the state (x, y, scale, θ), c = cos θ, s = sin θ."""
    return (
        x + scale * (c * point[0] - s * point[1]),
        y + scale * (s * point[0] + c * point[1]),
        c * normal[0] - s * normal[1],
        s * normal[0] + c * normal[1],
    )


@numba.njit(cache=True, fastmath=True, nogil=True, parallel=True)
def _contour_costs(
    edges: np.ndarray,
    motion: np.ndarray,
    use_motion: bool,
    particles: np.ndarray,
    labels: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    search_halfwidth: float,
    miss_penalty: float,
    orientation_tolerance: float,
    reference_scale: float,
    costs: np.ndarray,
    matched: np.ndarray,
    moving: np.ndarray,
    squared_distances: np.ndarray,
) -> None:
    height, width = edges.shape
    num_points = points.shape[1]
    miss = 2.0 * miss_penalty if use_motion else miss_penalty
    # Edge labels are orientations in [0, 180): two within the tolerance t of each other either
    # way round the half-turn are |a - b| <= t or >= 180 - t apart (every pair when t >= 90).
    tolerance_degrees = np.degrees(orientation_tolerance)
    opposite_degrees = 180.0 - tolerance_degrees
    # A rotation by θ turns every normal by θ: one arctan2 per template point, not per particle,
    # and the sum of two orientations in [0, 180) brought back into it by one comparison per
    # point (a float modulo per point and particle took 13 % of the filter's step).
    template_degrees = np.degrees(np.arctan2(normals[:, :, 1], normals[:, :, 0])) % 180.0
    for i in numba.prange(particles.shape[0]):
        shape = labels[i]
        x = particles[i, 0]
        y = particles[i, 1]
        scale = particles[i, 2]
        c = np.cos(particles[i, 3])
        s = np.sin(particles[i, 3])
        turn_degrees = np.degrees(particles[i, 3]) % 180.0
        # A contour smaller than the reference scale searches δ in proportion and counts its
        # distances in the reference's pixels: the inner features of a face then do not fit a
        # shrunken head-and-shoulders as well as the outline fits the whole one.
        shrink = min(1.0, scale / reference_scale) if reference_scale > 0.0 else 1.0
        reach = int(np.ceil(search_halfwidth * shrink))
        total = 0.0
        found_total = 0.0
        hits = 0
        moving_hits = 0
        for j in range(num_points):
            px, py, nx, ny = _placed(x, y, scale, c, s, points[shape, j], normals[shape, j])
            # Modulo 180 once per point, so that each probe only compares.
            normal_degrees = template_degrees[shape, j] + turn_degrees
            if normal_degrees >= 180.0:
                normal_degrees -= 180.0
            found = -1.0
            zu = 0
            zv = 0
            # Walk outwards from the point so the first edge met is the closest one: the point
            # itself, then both sides at each distance t < δ.
            for t in range(reach):
                for side in range(2 if t > 0 else 1):
                    step = t if side == 0 else -t
                    u = _pixel(px + step * nx)
                    v = _pixel(py + step * ny)
                    if 0 <= u < width and 0 <= v < height and edges[v, u] != 0:
                        gap = abs(normal_degrees - (edges[v, u] - 1.0))
                        if gap <= tolerance_degrees or gap >= opposite_degrees:
                            found = t
                            zu = u
                            zv = v
                            break
                if found >= 0.0:
                    break
            if found >= 0.0:
                found_total += found * found
                phi = (found / shrink) * (found / shrink)
                if use_motion:
                    if motion[zv, zu] == 0:
                        phi += miss_penalty
                    else:
                        moving_hits += 1
                total += phi
                hits += 1
            else:
                total += miss
        costs[i] = total
        matched[i] = hits
        moving[i] = moving_hits
        squared_distances[i] = found_total


def contour_costs(
    edges: np.ndarray,
    particles: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    *,
    search_halfwidth: float,
    miss_penalty: float,
    motion: np.ndarray | None = None,
    orientation_tolerance: float = np.pi / 2,
    labels: np.ndarray | None = None,
    reference_scale: float = 0.0,
) -> ContourFit:
    """Σ_j φ(j) for every particle (eq. 2, or eq. 3-4 when a motion mask is given).

    Args:
        edges: ``(H, W) uint8`` edge image from :func:`edge_map`: 0 off edges, else 1 + the
            gradient orientation in degrees modulo 180.
        particles: ``(P, 4) float64`` states x, y (pixels), s (pixels/unit), θ (radians).
        points: ``(N, 2) float64`` template measurement points, template units; or
            ``(K, N, 2)``, the points of K shapes, with ``labels``.
        normals: ``(N, 2) float64`` (or ``(K, N, 2)``) unit normals at the points.
        search_halfwidth: δ, pixels searched on each side of a point along its normal.
        miss_penalty: ρ, the cost of a point with no edge within δ (2ρ with motion).
        motion: Optional ``(H, W) uint8`` mask, non-zero where the optical flow or the
            background model says the pixel moves (γ = 0 there).
        orientation_tolerance: Largest angle, radians, between an edge's gradient and the
            contour normal for the edge to count; π/2 accepts every edge (the paper's model).
        labels: ``(P,)`` each particle's shape, an index into the K shapes (0 when None).
        reference_scale: s_ref, pixels per template unit: a particle of scale s < s_ref
            searches δ s / s_ref and its d(j) count times s_ref / s (the fit measured in the
            contour's own size); 0: δ and d(j) in pixels at every scale, as in the paper.

    Returns:
        The costs Σ_j φ(j) and, per particle, how many points found an edge within δ, how
        many of those edges move (0 without a motion mask) and the sum of their d(j)².
    """
    if search_halfwidth <= 0:
        raise ValueError(f'search_halfwidth (δ) must be > 0, got {search_halfwidth}')
    if edges.ndim != 2:
        raise ValueError(f'edges must be a 2-D image, got shape {edges.shape}')
    use_motion = motion is not None
    if motion is None:
        motion = edges
    elif motion.shape != edges.shape:
        raise ValueError(f'motion mask shape {motion.shape} differs from edges {edges.shape}')
    costs = np.empty(particles.shape[0], dtype=np.float64)
    matched = np.empty(particles.shape[0], dtype=np.int64)
    moving = np.empty(particles.shape[0], dtype=np.int64)
    squared_distances = np.empty(particles.shape[0], dtype=np.float64)
    points, normals, labels = _shapes(points, normals, labels, particles.shape[0])
    _contour_costs(
        np.ascontiguousarray(edges, dtype=np.uint8),
        np.ascontiguousarray(motion, dtype=np.uint8),
        use_motion,
        np.ascontiguousarray(particles, dtype=np.float64),
        labels,
        points,
        normals,
        float(search_halfwidth),
        float(miss_penalty),
        float(orientation_tolerance),
        float(reference_scale),
        costs,
        matched,
        moving,
        squared_distances,
    )
    return ContourFit(costs, matched, moving, squared_distances)


@numba.njit(cache=True, fastmath=True, nogil=True, parallel=True)
def _colour_costs(
    skin: np.ndarray,
    particles: np.ndarray,
    labels: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    depth: float,
    samples: int,
    interior_weight: float,
    costs: np.ndarray,
    interior_skin: np.ndarray,
) -> None:
    height, width = skin.shape
    num_points = points.shape[1]
    for i in numba.prange(particles.shape[0]):
        shape = labels[i]
        x = particles[i, 0]
        y = particles[i, 1]
        scale = particles[i, 2]
        c = np.cos(particles[i, 3])
        s = np.sin(particles[i, 3])
        step = depth * scale / samples
        total = 0.0
        skin_inside = 0.0
        for j in range(num_points):
            px, py, nx, ny = _placed(x, y, scale, c, s, points[shape, j], normals[shape, j])
            inside_not_skin = 0.0
            outside_skin = 0.0
            for k in range(1, samples + 1):
                for sign in (-1.0, 1.0):
                    u = _pixel(px + sign * k * step * nx)
                    v = _pixel(py + sign * k * step * ny)
                    label = 1.0 if 0 <= u < width and 0 <= v < height and skin[v, u] != 0 else 0.0
                    if sign < 0.0:
                        inside_not_skin += 1.0 - label
                    else:
                        outside_skin += label
            total += (inside_not_skin / interior_weight + outside_skin) / samples
            skin_inside += samples - inside_not_skin
        costs[i] = total
        interior_skin[i] = skin_inside / (samples * num_points)


def colour_costs(
    skin: np.ndarray,
    particles: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    *,
    interior_weight: float = 2.0,
    depth: float = 0.1,
    samples: int = 3,
    labels: np.ndarray | None = None,
) -> ColourFit:
    """Σ_j γ_colour(j) for every particle: the colour term of §3.2.

    Args:
        skin: ``(H, W) uint8`` skin labels, non-zero on skin.
        particles: ``(P, 4) float64`` states x, y (pixels), s (pixels/unit), θ (radians).
        points: ``(N, 2) float64`` template measurement points, template units.
        normals: ``(N, 2) float64`` unit normals at the points, pointing outwards.
        interior_weight: w > 1, the weight dividing the interior term.
        depth: How far into the interior and exterior the labels are sampled, template
            units (a fraction of the reference region's width).
        samples: Samples on each side of every point.
        labels: ``(P,)`` each particle's shape when ``points`` and ``normals`` are
            ``(K, N, 2)``, as in :func:`contour_costs`.

    Returns:
        Per particle, the sum over points of γ_colour(j) (each in [0, 1 + 1/w]) and the
        share of interior samples on skin.
    """
    if interior_weight <= 1.0:
        raise ValueError(f'interior_weight (w) must be > 1, got {interior_weight}')
    if depth <= 0 or samples < 1:
        raise ValueError(f'need depth > 0 and samples >= 1, got {depth}, {samples}')
    if skin.ndim != 2:
        raise ValueError(f'skin labels must be a 2-D image, got shape {skin.shape}')
    costs = np.empty(particles.shape[0], dtype=np.float64)
    interior_skin = np.empty(particles.shape[0], dtype=np.float64)
    points, normals, labels = _shapes(points, normals, labels, particles.shape[0])
    _colour_costs(
        np.ascontiguousarray(skin, dtype=np.uint8),
        np.ascontiguousarray(particles, dtype=np.float64),
        labels,
        points,
        normals,
        float(depth),
        int(samples),
        float(interior_weight),
        costs,
        interior_skin,
    )
    return ColourFit(costs, interior_skin)


def _shapes(
    points: np.ndarray, normals: np.ndarray, labels: np.ndarray | None, count: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points and normals as ``(K, N, 2) float64`` and the ``(P,) int64`` labels indexing them."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    normals = np.ascontiguousarray(normals, dtype=np.float64)
    if points.ndim == 2:
        points, normals = points[None], normals[None]
    if points.shape != normals.shape or points.ndim != 3 or points.shape[2] != 2:
        raise ValueError(f'points {points.shape} and normals {normals.shape} must both be (N, 2) or (K, N, 2)')
    if labels is None:
        return points, normals, np.zeros(count, dtype=np.int64)
    labels = np.ascontiguousarray(labels, dtype=np.int64)
    if labels.shape != (count,) or (count and not 0 <= labels.min() <= labels.max() < points.shape[0]):
        raise ValueError(f'labels must be ({count},) indices of the {points.shape[0]} shapes')
    return points, normals, labels


def log_likelihood(costs: np.ndarray, likelihood_gain: float) -> np.ndarray:
    """Eq. 1 in the log domain: ``log p(z | x_i) = -K Σ_j φ(j)`` up to a constant."""
    return -likelihood_gain * np.asarray(costs, dtype=np.float64)


def normalised_weights(log_weights: np.ndarray) -> np.ndarray:
    """Particle weights summing to one from unnormalised log weights (overflow-safe)."""
    shifted = np.exp(log_weights - np.max(log_weights))
    return shifted / shifted.sum()
