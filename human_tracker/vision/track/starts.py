"""Where a track starts: X_0 from a region (§2.5), hypotheses scored around it, a start box.

The moving region's (or a hand's skin regions') X_0 is a hypothesis, scored by the contour's
fit in a small cloud around it (:func:`best_hypothesis`). :func:`should_start` says when a
hypothesis starts the filter: there is no target and it fits well enough, or it is clearly
better elsewhere (``switch_margin``); :func:`may_switch` when looking for one elsewhere is worth
it. :func:`settle_on_box` starts the filter where the contour fits best around a start box.
Everything here is in working pixels.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import cv2
import numpy as np

from human_tracker.vision.cues.morphology import disk
from human_tracker.vision.cues.skin import SKIN
from human_tracker.vision.filter.contour_filter import Appearance, ContourTracker, TrackEstimate, state_from_box
from human_tracker.vision.filter.particle_filter import gaussian_cloud
from human_tracker.vision.filter.templates import ContourTemplate
from human_tracker.vision.geometry.boxes import Box
from human_tracker.vision.track.initialisation import blobs, moments_state, state_from_scan, upper_end_state
from human_tracker.vision.track.parameters import StartParameters, TargetParameters

__all__ = [
    'START_OFFSETS',
    'START_SCALES',
    'Hypothesis',
    'best_hypothesis',
    'cleared',
    'initial_region',
    'initial_states',
    'may_switch',
    'settle_on_box',
    'should_start',
]

START_SCALES = tuple(np.round(np.linspace(1.0, 1.8, 9), 2))
"""Scale factors of the contour sought around a start box."""
START_OFFSETS = (tuple(np.round(np.linspace(-0.3, 0.3, 7), 2)), tuple(np.round(np.linspace(-0.6, 0.3, 10), 2)))
"""x and y offsets, in units of the box's scale, of the contour sought around a start box: the
head-and-shoulders outline around a face box is larger and higher."""


class Hypothesis(NamedTuple):
    """A candidate state from a region and how well it fits.

    Attributes:
        state: ``(4,)`` [x, y, s, θ] in working pixels (what the filter is initialised with).
        confidence: Fraction of contour points that found an edge.
        motion_support: Fraction of contour points whose edge moves.
        skin_support: Share of the contour's interior on skin (1 without skin labels).
        appearance_distance: Bhattacharyya distance of its region from the target's
            reference (0 while the appearance is unknown).
    """

    state: np.ndarray
    confidence: float
    motion_support: float
    skin_support: float = 1.0
    appearance_distance: float = 0.0


def initial_region(
    motion: np.ndarray | None, skin: np.ndarray | None, parameters: StartParameters, cleared_boxes: Sequence[Box] = ()
) -> np.ndarray | None:
    """The mask X_0 is computed from (``init_region``; the other cue when that one is missing),
    or None without either; zero on ``cleared_boxes`` (x, y, w, h: other targets', faces kept off)."""
    if skin is not None:
        # Only the paper's skin clusters: parts of mixed ones (beside clothes of a near colour)
        # join the hand to the skin-coloured things next to it, and its X_0 strays.
        skin = np.where(skin == SKIN, skin, 0).astype(np.uint8)
    if parameters.init_region == 'skin' and skin is not None:
        region = skin
    else:
        region = motion if motion is not None else skin
    return region if region is None or not cleared_boxes else cleared(region, cleared_boxes)


def initial_states(
    region: np.ndarray, template: ContourTemplate, parameters: StartParameters, started: bool
) -> list[np.ndarray]:
    """Candidate X_0 from a region mask (§2.5), ``parameters`` scaled to its resolution; empty
    if there is no usable region. ``started``: the filter has been started before
    (``upper_end_restarts``)."""
    p = parameters
    if p.region_closing:
        # Join the silhouette's moving parts into one region; the likelihood keeps the tight
        # mask so that still edges next to a moving person do not count as moving.
        region = cv2.morphologyEx(region, cv2.MORPH_CLOSE, disk(p.region_closing))
    if p.init_method == 'moments':
        starts = []
        for blob in blobs(region, p.min_blob_area, p.hypothesis_blobs):
            end = upper_end_state(blob, template) if p.upper_end_restarts and started else None
            starts.append(moments_state(blob, template) if end is None else end)
        return starts
    start = state_from_scan(region, template, upright_angle=p.upright_angle, min_area=p.min_blob_area)
    return [] if start is None else [start]


def best_hypothesis(
    filter: ContourTracker,
    starts: Sequence[np.ndarray],
    edges: np.ndarray,
    parameters: StartParameters,
    motion: np.ndarray | None = None,
    skin: np.ndarray | None = None,
    appearance: Appearance | None = None,
) -> Hypothesis | None:
    """The best-fitting state in clouds around ``starts`` (X_0s), with its scores; None when
    none can start. The clouds are drawn from ``filter``'s generator."""
    fp = filter.parameters
    best: tuple[float, Hypothesis] | None = None
    n = filter.template.num_points
    # With a motion mask a start needs init_motion_support: a cloud with no moving pixel within
    # reach of its contours (their points, and δ along the normals) could not start, and
    # scored, it could hide a moving region that can.
    needs_motion = motion is not None and parameters.init_motion_support > 0
    # The farthest a contour point of any of the template's shapes lies from its origin.
    reach = max(float(np.hypot(*shape.points.T).max()) for shape in filter.template.shapes)
    for start in starts:
        if not fp.min_scale <= start[2] <= fp.max_scale:
            continue
        # Twice the initial spread: X_0 from a mask is coarse, the cloud must reach the silhouette.
        cloud = gaussian_cloud(start, 2.0 * np.asarray(fp.initial_spread), parameters.hypothesis_samples, filter.rng)
        cloud[0] = start
        np.clip(cloud[:, 2], fp.min_scale, fp.max_scale, out=cloud[:, 2])
        # Skipped after its draws, so that the random stream, and every later draw, stays the same.
        if needs_motion and not _moves_within(motion, cloud, reach, fp.search_halfwidth):
            continue
        fit = filter.fit(edges, cloud, motion, skin)
        # With colour the likelihood itself ranks the states; edges alone would favour small
        # contours that fit any clutter, so they rank by points on (moving) edges.
        score = -fit.costs if skin is not None else fit.matched + fit.moving - 1e-6 * fit.costs
        k = int(np.argmax(score))
        if best is None or score[k] > best[0]:
            skin_support = 1.0 if fit.skin is None else float(fit.skin[k])
            distance = 0.0 if appearance is None else float(np.sqrt(appearance(cloud[k : k + 1])[0]))
            hypothesis = Hypothesis(
                cloud[k], float(fit.matched[k]) / n, float(fit.moving[k]) / n, skin_support, distance
            )
            best = (float(score[k]), hypothesis)
    return None if best is None else best[1]


def should_start(
    found: Hypothesis, estimate: TrackEstimate | None, tracking: bool, moving: bool, parameters: TargetParameters
) -> bool:
    """Whether ``found`` starts the filter: there is no target (not ``tracking``) and it fits
    (``init_confidence``), or it is clearly better elsewhere than ``estimate``
    (``switch_margin`` more motion support). ``moving``: the frame has a motion mask."""
    p = parameters
    if moving and found.motion_support < p.init_motion_support:
        return False
    if found.skin_support < p.lost_skin_support or found.appearance_distance > p.lost_appearance_distance:
        return False  # it would be a weak frame at once
    if not tracking or estimate is None:
        return found.confidence >= p.init_confidence
    far = np.hypot(*(found.state[:2] - estimate.state[:2])) > 0.5 * estimate.state[2]
    fits = found.confidence >= p.lost_confidence
    return far and fits and found.motion_support >= estimate.motion_support + p.switch_margin


def may_switch(
    estimate: TrackEstimate | None, tracking: bool, named_by_box: bool, parameters: TargetParameters
) -> bool:
    """Whether a hypothesis could start the filter (when not, the search is skipped): not while
    the estimate's motion support is within ``switch_margin`` of 1 (no hypothesis's exceeds 1),
    nor while a target named by a start box (``named_by_box``: started from one, its appearance
    known) holds its edges and colours: a region moving more elsewhere (someone walking past)
    does not take over a still person."""
    if not tracking or estimate is None:
        return True
    p = parameters
    holds = estimate.confidence >= p.lost_confidence and estimate.appearance_distance <= p.lost_appearance_distance
    if named_by_box and holds:
        return False
    return estimate.motion_support + p.switch_margin <= 1.0


def settle_on_box(
    filter: ContourTracker,
    box: Box,
    edges: np.ndarray,
    motion: np.ndarray | None = None,
    skin: np.ndarray | None = None,
) -> np.ndarray:
    """The state where the contour best fits the silhouette around a start ``box`` (x, y, w, h).

    A start box need not be the template's reference region (a face box is smaller and lower
    than the head-and-shoulders outline around it): the contour is fitted on a grid of scales
    and offsets around the box (:data:`START_SCALES`, :data:`START_OFFSETS`, in units of the
    box's own scale); the lowest Σ φ (eqs. 2-4) wins, the box's own state on a tie.
    """
    fp = filter.parameters
    start = state_from_box(box, filter.template)
    s0 = start[2]
    grid = np.array(
        [
            [start[0] + dx * s0, start[1] + dy * s0, s0 * factor, 0.0]
            for factor in START_SCALES
            for dy in START_OFFSETS[1]
            for dx in START_OFFSETS[0]
        ]
    )
    grid = np.vstack([start, grid])  # the box's own state first: it wins ties (a frame with no edges)
    np.clip(grid[:, 2], fp.min_scale, fp.max_scale, out=grid[:, 2])
    return grid[int(np.argmin(filter.fit(edges, grid, motion, skin).costs))]


def cleared(mask: np.ndarray, boxes: Sequence[Box]) -> np.ndarray:
    """A copy of ``mask`` with zeros on ``boxes`` (x, y, w, h, its pixels)."""
    mask = mask.copy()
    for x, y, w, h in boxes:
        mask[max(0, int(y)) : max(0, int(y + h)), max(0, int(x)) : max(0, int(x + w))] = 0
    return mask


def _moves_within(motion: np.ndarray, states: np.ndarray, reach: float, margin: float) -> bool:
    """Whether ``motion`` (non-zero on moving pixels) has a moving pixel within ``reach``
    template units of a state's position (times its scale) plus ``margin`` pixels, for some
    of the ``(P, 4)`` ``states``: the pixels their contours' motion support is counted on."""
    radius = reach * float(states[:, 2].max()) + margin
    left, top = (max(0, int(np.floor(v - radius))) for v in states[:, :2].min(axis=0))
    right, bottom = (max(0, int(np.ceil(v + radius)) + 1) for v in states[:, :2].max(axis=0))
    return bool(np.any(motion[top:bottom, left:right]))
