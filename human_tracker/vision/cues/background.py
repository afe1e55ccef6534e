"""Background subtraction after Donohoe et al., with the paper's modification (§2.4.1).

Each pixel's intensity i_k is tested between two hypotheses:

- target:      p(i | target) = 1 / n, uniform over the n intensity levels;
- background:  p(i | background) = N(m_{k-1}, σ²_{k-1}), m the dynamic reference frame.

The pixel is background when ``p(i | background) / p(i | target) > λ`` (``threshold``), that
is when ``(i - m)² < 2 σ² ln(n / (λ sqrt(2π σ²)))``. Then, and only then (the paper's
modification, so a slow hand or a still forearm is not absorbed into the background),
``m_k = α i_k + (1 - α) m_{k-1}`` and likewise ``σ²_k = α (i_k - m_{k-1})² + (1 - α) σ²_{k-1}``.
σ² is kept within ``[min_variance, max_variance]`` so the test cannot degenerate (σ → 0
would call every pixel target; σ → ∞ every pixel background). A morphological opening and
closing clean the mask.

With that modification a pixel judged target is never relearnt, so an object that was in
the reference frame and then left (a person standing there when the node started) stays
foreground for ever: a "ghost". ``foreground_learning_rate`` (0 by default, the paper's
rule) optionally updates target pixels too, much more slowly than background ones, so that
ghosts fade; it also slowly absorbs a person who stands still for long.

The same rule never lets the model recover once most of the frame differs from it: a camera's
automatic exposure jumps, the light changes, the camera moves further than its compensation
follows. The mask is then *flooded* (more than
``flooded_fraction`` of the frame) and isolates nothing; after ``flooded_frames`` such masks
in a row (0: never, the paper's model) the model starts again from the frame, as on the first
one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numba
import numpy as np

from human_tracker.vision.checks import parameter
from human_tracker.vision.cues.camera_motion import CameraMotion, scale_transform
from human_tracker.vision.cues.morphology import disk

__all__ = ['BackgroundParameters', 'BackgroundModel', 'background_decision']


@dataclass
class BackgroundParameters:
    """Constants of the background model.

    Attributes:
        learning_rate: α of the first-order filter, in [0, 1] (per frame).
        foreground_learning_rate: Rate at which pixels judged target are learnt, in [0, 1];
            0 is the paper's rule (never).
        threshold: λ of the likelihood-ratio test (the paper selects 1).
        intensity_levels: n, number of intensity levels (256 for 8-bit images).
        initial_variance: σ² of every pixel before any update, grey levels².
        min_variance: Lower bound of σ², grey levels².
        max_variance: Upper bound of σ², grey levels².
        opening_radius: Radius (pixels) of the opening that removes isolated false
            detections; 0 disables it.
        closing_radius: Radius (pixels) of the closing that fills small holes; 0 disables it.
        compensate_camera: Carry the reference frame with the camera's own image motion
            (:mod:`~human_tracker.vision.cues.camera_motion`, estimated between consecutive
            frames, the last foreground left out) before each test, so that a turning or
            swaying camera does not make the whole scene foreground. Pixels that come into
            view start afresh. On a fixed camera the estimate is the identity.
        flooded_fraction: Share of the frame above which a mask is flooded, in (0, 1].
        flooded_frames: Flooded masks in a row after which the model starts again from the
            frame; 0 never does: the paper's model.
    """

    learning_rate: float = parameter(
        0.05, 'α: rate of the first-order filter of m and σ² on background pixels, per frame.', low=0.0, high=1.0
    )
    foreground_learning_rate: float = parameter(
        0.0, 'Rate at which pixels judged target are learnt; 0: never (the paper), > 0: ghosts fade.', low=0.0, high=1.0
    )
    threshold: float = parameter(
        1.0, 'λ: likelihood-ratio threshold background / target (the paper uses 1).', low=1e-06, high=1000000.0
    )
    intensity_levels: int = parameter(256, 'n: intensity levels of the uniform target density 1/n.', low=2, high=65536)
    initial_variance: float = parameter(
        25.0, 'σ² of every pixel when the model starts, grey levels².', low=0.001, high=100000.0
    )
    min_variance: float = parameter(
        4.0,
        'Lower bound of σ², grey levels² (keeps the test from calling every pixel target).',
        low=0.001,
        high=100000.0,
    )
    max_variance: float = parameter(
        400.0,
        'Upper bound of σ², grey levels² (keeps the test from calling every pixel background).',
        low=0.001,
        high=100000.0,
    )
    opening_radius: int = parameter(
        1, 'Morphological opening radius, pixels (removes isolated detections).', low=0, high=50
    )
    closing_radius: int = parameter(3, 'Morphological closing radius, pixels (fills holes).', low=0, high=50)
    compensate_camera: bool = parameter(True, "Carry the reference frame with the camera's own image motion.")
    flooded_fraction: float = parameter(
        0.5, 'Share of the frame above which a mask is flooded (the model no longer fits).', low=0.001, high=1.0
    )
    flooded_frames: int = parameter(
        5, 'Flooded masks in a row after which the model restarts; 0: never.', low=0, high=1000
    )

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        checks = [
            (0.0 <= self.learning_rate <= 1.0, f'learning_rate (α) must be in [0, 1], got {self.learning_rate}'),
            (
                0.0 <= self.foreground_learning_rate <= 1.0,
                f'foreground_learning_rate must be in [0, 1], got {self.foreground_learning_rate}',
            ),
            (self.threshold > 0, f'threshold (λ) must be > 0, got {self.threshold}'),
            (self.intensity_levels >= 2, f'intensity_levels (n) must be >= 2, got {self.intensity_levels}'),
            (
                0 < self.min_variance <= self.max_variance,
                f'need 0 < min_variance <= max_variance, got {self.min_variance}, {self.max_variance}',
            ),
            (self.initial_variance > 0, f'initial_variance must be > 0, got {self.initial_variance}'),
            (self.opening_radius >= 0 and self.closing_radius >= 0, 'morphology radii must be >= 0'),
            (0.0 < self.flooded_fraction <= 1.0, f'flooded_fraction must be in (0, 1], got {self.flooded_fraction}'),
            (self.flooded_frames >= 0, f'flooded_frames must be >= 0, got {self.flooded_frames}'),
        ]
        for ok, message in checks:
            if not ok:
                raise ValueError(message)


def background_decision(
    intensity: np.ndarray,
    mean: np.ndarray,
    variance: np.ndarray,
    threshold: float = 1.0,
    intensity_levels: int = 256,
) -> np.ndarray:
    """Steps 1-2 of §2.4.1: True where the pixel is background.

    Args:
        intensity: i_k, any shape, grey levels.
        mean: m_{k-1}, same shape.
        variance: σ²_{k-1}, same shape, grey levels² (> 0).
        threshold: λ.
        intensity_levels: n.

    Returns:
        Boolean array: ``N(i; m, σ²) / (1/n) > λ``.
    """
    variance = np.asarray(variance, dtype=np.float32)
    squared = np.square(np.asarray(intensity, dtype=np.float32) - mean)
    # log N(i; m, σ²) + log n > log λ, rearranged so no exponential can underflow.
    bound = 2.0 * variance * (np.log(intensity_levels / threshold) - 0.5 * np.log(2.0 * np.pi * variance))
    return squared < bound


@numba.njit(cache=True, fastmath=True, nogil=True, parallel=True)
def _decide_and_update(
    frame: np.ndarray,
    mean: np.ndarray,
    variance: np.ndarray,
    mask: np.ndarray,
    log_n_over_lambda: float,
    learning_rate: float,
    foreground_learning_rate: float,
    min_variance: float,
    max_variance: float,
) -> None:
    """Steps 1-3 of §2.4.1 in one pass per pixel (the same arithmetic as
    :func:`background_decision` and the update); mask gets 255 on target pixels."""
    half_log_two_pi = 0.5 * np.log(2.0 * np.pi)
    height, width = frame.shape
    for v in numba.prange(height):
        for u in range(width):
            m = mean[v, u]
            s2 = variance[v, u]
            d = np.float32(frame[v, u]) - m
            bound = 2.0 * s2 * (log_n_over_lambda - half_log_two_pi - 0.5 * np.log(s2))
            is_background = d * d < bound
            mask[v, u] = 0 if is_background else 255
            alpha = learning_rate if is_background else foreground_learning_rate
            mean[v, u] = m + alpha * d
            s2 = s2 + alpha * (d * d - s2)
            variance[v, u] = min(max(s2, min_variance), max_variance)


@dataclass
class BackgroundModel:
    """The dynamic reference frame m and noise variance σ² of every pixel.

    ``apply(gray)`` classifies a frame, updates the model on its background pixels and
    returns the cleaned foreground mask. The fields are the model's whole state;
    ``camera_motion`` is the camera's image motion from the previous frame to the last one
    applied (``(2, 3)``, :mod:`~human_tracker.vision.cues.camera_motion`, in that frame's pixels),
    None where it is not known (``compensate_camera`` off, the first frame, a blank frame);
    ``flooded`` counts the flooded masks in a row and ``restarts`` the times the model started
    again from a frame because of them.
    """

    parameters: BackgroundParameters = field(default_factory=BackgroundParameters)
    mean: np.ndarray | None = None
    variance: np.ndarray | None = None
    previous: np.ndarray | None = None
    foreground: np.ndarray | None = None
    camera: CameraMotion = field(default_factory=CameraMotion)
    camera_motion: np.ndarray | None = None
    flooded: int = 0
    restarts: int = 0

    def __post_init__(self) -> None:
        self.parameters.validate()

    def reset(self) -> None:
        """Forget the background; the next frame becomes the reference."""
        self.mean = None
        self.variance = None
        self.previous = None
        self.foreground = None
        self.camera_motion = None
        self.flooded = 0
        self.camera.reset()

    def apply(self, gray: np.ndarray) -> np.ndarray:
        """Classify ``gray`` and update the model (step 3).

        Args:
            gray: ``(H, W)`` intensity image (uint8 or float).

        Returns:
            ``(H, W) uint8`` foreground mask, 255 on target pixels, 0 on background; a flooded
            mask is returned as it is, the model starting again from ``gray`` after it.
        """
        p = self.parameters
        # uint8 frames go to the kernel as they are: a float copy of the frame costs more than the test.
        frame = np.asarray(gray)
        self.camera_motion = None
        if self.mean is None or self.variance is None or self.mean.shape != frame.shape:
            # The first frame (or a new image size) is taken as background.
            self._start_from(frame)
            self.previous = frame if frame.dtype == np.uint8 else None
            self.foreground = None
            self.camera.reset()
            return np.zeros(frame.shape, dtype=np.uint8)
        if p.compensate_camera and frame.dtype == np.uint8 and self.previous is not None:
            self._follow_camera(frame)
        mask = np.empty(frame.shape, dtype=np.uint8)
        _decide_and_update(
            frame,
            self.mean,
            self.variance,
            mask,
            np.float32(np.log(p.intensity_levels / p.threshold)),
            np.float32(p.learning_rate),
            np.float32(p.foreground_learning_rate),
            np.float32(p.min_variance),
            np.float32(p.max_variance),
        )
        if p.opening_radius:
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, disk(p.opening_radius))
        if p.closing_radius:
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, disk(p.closing_radius))
        self.previous = frame if frame.dtype == np.uint8 else None
        self.foreground = mask
        if p.flooded_frames:
            self.flooded = self.flooded + 1 if np.count_nonzero(mask) > p.flooded_fraction * mask.size else 0
            if self.flooded >= p.flooded_frames:
                # The reference no longer describes the scene, and target pixels are never
                # learnt: left alone it would stay flooded for good.
                self._start_from(frame)
                self.flooded = 0
                self.restarts += 1
        return mask

    def _start_from(self, frame: np.ndarray) -> None:
        """Take ``frame`` as the reference, every pixel at ``initial_variance``."""
        self.mean = frame.astype(np.float32)
        self.variance = np.full(frame.shape, self.parameters.initial_variance, dtype=np.float32)

    def _follow_camera(self, frame: np.ndarray) -> None:
        """Carry the reference frame with the camera's motion from the previous frame to ``frame``."""
        assert self.mean is not None and self.variance is not None and self.previous is not None
        self.camera_motion = transform = self.camera.estimate(self.previous, frame, self.foreground)
        if transform is None:
            return  # nothing to follow (a blank frame): keep the model as it is
        if np.array_equal(transform, np.eye(2, 3)):
            return
        size = (frame.shape[1], frame.shape[0])
        seen = cv2.warpAffine(np.ones(frame.shape, np.uint8), transform, size, flags=cv2.INTER_NEAREST) > 0
        self.mean = np.where(seen, cv2.warpAffine(self.mean, transform, size), frame).astype(np.float32)
        variance = cv2.warpAffine(self.variance, transform, size)
        self.variance = np.where(seen, variance, self.parameters.initial_variance).astype(np.float32)

    def camera_motion_in(self, width: int) -> np.ndarray | None:
        """``camera_motion`` in the pixels of the same frame ``width`` pixels wide (the camera's,
        where the model runs on a reduced frame); None where it is not known."""
        if self.camera_motion is None or self.mean is None:
            return None
        return scale_transform(self.camera_motion, width / self.mean.shape[1])

    def reference_frame(self) -> np.ndarray | None:
        """The dynamic reference frame m as ``uint8`` (the background estimate), or None."""
        return None if self.mean is None else np.clip(self.mean, 0, 255).astype(np.uint8)
