"""One frame's evidence: the camera frame and its cues, built once and read by every target.

An :class:`Evidence` holds what the cue stages measured on a frame (the motion mask, the skin
labels, the camera's motion) with the frame itself and its stamp. Each target's filter reads it
at its own working resolution (:meth:`Evidence.working`): the reduced and brightened image, its
edges and its colour bins are computed once per set of settings and shared by every target that
works with the same ones. :func:`working_cues` brings the masks to that resolution and makes
the paper's choice of how each cue enters the fit (``motion_mode``, ``colour_mode``): in the
likelihood, or as the area the edges are taken from.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import cv2
import numpy as np

from human_tracker.vision.cues.appearance import colour_bins
from human_tracker.vision.cues.edges import edge_map
from human_tracker.vision.cues.exposure import normalise_exposure
from human_tracker.vision.cues.morphology import disk
from human_tracker.vision.cues.parameters import CueParameters
from human_tracker.vision.cues.resolution import same_frame, to_working, working_shape

__all__ = ['Cues', 'Evidence', 'FrameSettings', 'WorkingFrame', 'at_working', 'working_cues', 'working_frame']


class FrameSettings(NamedTuple):
    """What a working frame depends on besides the camera frame.

    Attributes:
        width: Working width, pixels (0: full size).
        colour_edges: Edges on the colour image (strongest channel), not on its intensity.
        colour_bins: Whether the colour bins are wanted (the fused likelihood's appearance).
        blur_sigma: The edge detector's Gaussian pre-filter, working pixels.
        canny_low: Canny low threshold.
        canny_high: Canny high threshold.
    """

    width: int
    colour_edges: bool
    colour_bins: bool
    blur_sigma: float
    canny_low: float
    canny_high: float


class WorkingFrame(NamedTuple):
    """A camera frame at a working resolution (working pixels).

    Attributes:
        image: ``(H, W)`` grey or ``(H, W, 3)`` BGR (``colour_edges``) working image, brightened
            (:func:`~human_tracker.vision.cues.exposure.normalise_exposure`): what the edges and the
            face detector see.
        grey: The working grey image before brightening (the camera-motion estimate's).
        edges: Its :func:`~human_tracker.vision.filter.measurement.edge_map`.
        bins: Its colour bins (:func:`~human_tracker.vision.cues.appearance.colour_bins`) when
            asked for, else None.
    """

    image: np.ndarray
    grey: np.ndarray
    edges: np.ndarray
    bins: np.ndarray | None


@dataclass(frozen=True)
class Evidence:
    """One camera frame and what the cue stages measured on it.

    Attributes:
        image: ``(H, W) uint8`` intensity image, or ``(H, W, 3) uint8`` BGR image.
        motion: ``uint8`` mask, non-zero on moving pixels (foreground or optical-flow motion),
            at any resolution of the frame (a cue stage works at its own width); None: no
            motion cue.
        skin: ``uint8`` skin labels (§3.2) at any resolution of the frame; None: no skin cue.
        camera_motion: The camera's image motion from the last frame to this one (``(2, 3)``,
            :mod:`~human_tracker.vision.cues.camera_motion`, camera pixels) as the background
            stage measured it; None: not measured.
        stamp_ns: The frame's time, nanoseconds; None: unknown.
    """

    image: np.ndarray
    motion: np.ndarray | None = None
    skin: np.ndarray | None = None
    camera_motion: np.ndarray | None = None
    stamp_ns: int | None = None
    # Working frames by their settings, and reduced images by width: computed on first use.
    _working: dict[object, object] = field(default_factory=dict, repr=False, compare=False)

    def with_cues(self, **cues: object) -> Evidence:
        """The same frame with cues added (``motion``, ``skin``, ...), keeping the working frames
        already computed (a node computes them while the cue stages work)."""
        values = {name: getattr(self, name) for name in ('motion', 'skin', 'camera_motion', 'stamp_ns')}
        return Evidence(self.image, **(values | cues), _working=self._working)

    def working(self, settings: FrameSettings) -> WorkingFrame:
        """The frame at ``settings`` (computed once per settings, :func:`working_frame`)."""
        frame = self._working.get(settings)
        if frame is None:
            frame = self._working[settings] = working_frame(self.image, settings, self._reduced)
        return frame  # type: ignore[return-value]

    def _reduced(self, width: int) -> tuple[np.ndarray, np.ndarray]:
        """The frame reduced to ``width``, as it is and brightened: computed once, it serves the
        colour bins and colour edges of every target at that width."""
        key = ('reduced', width)
        if key not in self._working:
            self._working[key] = _reduce(self.image, width)
        return self._working[key]  # type: ignore[return-value]


def working_frame(
    image: np.ndarray,
    settings: FrameSettings,
    reduce: Callable[[int], tuple[np.ndarray, np.ndarray]] | None = None,
) -> WorkingFrame:
    """``image`` at ``settings``: reduced, brightened, its edges and colour bins.

    ``reduce``: gives ``image`` reduced to a width, as it is and brightened (a cache of it); None:
    computed here. A colour frame's edges come from its grey image reduced (unless
    ``colour_edges``), as the cue stages do: a colour frame and its grey version then give the
    same edges.
    """
    small = gained = None
    if settings.colour_bins or settings.colour_edges or image.ndim == 2:
        small, gained = (reduce or (lambda width: _reduce(image, width)))(settings.width)
    bins = colour_bins(gained) if settings.colour_bins else None
    if small is None or (small.ndim == 3 and not settings.colour_edges):
        small = to_working(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), settings.width)
        gained = normalise_exposure(small)
    grey = small if small.ndim == 2 else cv2.cvtColor(small, cv2.COLOR_BGR2GRAY)
    edges = edge_map(
        gained, blur_sigma=settings.blur_sigma, low_threshold=settings.canny_low, high_threshold=settings.canny_high
    )
    return WorkingFrame(gained, grey, edges, bins)


def _reduce(image: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
    """``image`` reduced to working ``width``, as it is and brightened."""
    small = to_working(image, width)
    return small, normalise_exposure(small)


class Cues(NamedTuple):
    """A frame's cues at a target's working resolution, as its parameters use them.

    Attributes:
        edges: The edge map the contour is fitted to: the frame's, or only its moving edges
            (``motion_mode: mask``) or those near skin (``colour_mode: mask``).
        motion: The motion mask (None without one, or when set aside): where hypotheses come
            from and what the motion-support test reads.
        skin: The skin labels (None without them): where a hand's hypotheses come from.
        likelihood_motion: The mask of eqs. 3-4 (``motion_mode: weighted``), else None.
        likelihood_skin: The labels of the colour term of §3.2 (``colour_mode: weighted``), else None.
        motion_set_aside: The frame's mask covered more than ``max_motion_fraction`` of it and
            is not used.
        evidence: The frame's evidence they come from (camera pixels): what a likelihood term
            of another cue reads (:class:`~human_tracker.vision.filter.likelihood.Observation`).
    """

    edges: np.ndarray
    motion: np.ndarray | None
    skin: np.ndarray | None
    likelihood_motion: np.ndarray | None
    likelihood_skin: np.ndarray | None
    motion_set_aside: bool
    evidence: Evidence


def working_cues(evidence: Evidence, frame: WorkingFrame, width: int, parameters: CueParameters) -> Cues:
    """The cues of ``evidence`` at working ``width`` for a target with ``parameters`` (scaled to
    the working frame): each cue in the likelihood or as a mask on ``frame``'s edges."""
    shape = evidence.image.shape[:2]
    motion = at_working('motion mask', evidence.motion, shape, width)
    set_aside = motion is not None and int(np.count_nonzero(motion)) > parameters.max_motion_fraction * motion.size
    if set_aside:
        motion = None
    skin = at_working('skin labels', evidence.skin, shape, width)
    edges, likelihood_motion, likelihood_skin = frame.edges, None, None
    if motion is not None and parameters.motion_mode == 'mask':
        edges = np.where(motion > 0, edges, 0).astype(np.uint8)
    elif motion is not None and parameters.motion_mode == 'weighted':
        likelihood_motion = motion
    if skin is not None and parameters.colour_mode == 'mask':
        near_skin = cv2.dilate(skin, disk(parameters.skin_margin))
        edges = np.where(near_skin > 0, edges, 0).astype(np.uint8)
    elif skin is not None and parameters.colour_mode == 'weighted':
        likelihood_skin = skin
    return Cues(edges, motion, skin, likelihood_motion, likelihood_skin, set_aside, evidence)


def at_working(name: str, mask: np.ndarray | None, shape: tuple[int, int], width: int) -> np.ndarray | None:
    """A cue mask of the frame ``shape``, at any resolution, brought to working ``width``.

    Raises:
        ValueError: ``mask`` cannot be the frame at any resolution (``name`` says which).
    """
    if mask is None:
        return None
    working = working_shape(shape, width)
    if mask.shape == working:
        return mask
    if not same_frame(mask.shape, shape):
        raise ValueError(f'{name} {mask.shape} cannot be the image {shape} at any resolution')
    return cv2.resize(mask, (working[1], working[0]), interpolation=cv2.INTER_NEAREST)
