"""A person's skin colour learnt from their own face (the LAAS follow-up of §3.2: Brèthes et al.,
ICRA 2004, learnt the hands' skin from the tracked face).

The face's five landmarks (:mod:`~human_tracker.vision.faces.yunet`: the eyes, the nose tip, the
mouth's corners) give an affine frame on the face; the cheeks, the forehead and the bridge of
the nose are patches in that frame, away from the eyes, brows, mouth, nostrils and hair. Their
pixels' (I2, I3), trimmed of what a Gaussian would not hold (a strand of hair, a spectacle
rim, a highlight), make one skin class: the person's. The general model (:func:`default_skin_model`)
stays the prior: a face whose skin lies outside it (a coloured light, a wrong face) teaches
nothing, and with no face the general model labels the frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from human_tracker.vision.cues.exposure import MAX_EXPOSURE_GAIN, normalise_exposure
from human_tracker.vision.cues.skin.model import SkinClass, SkinModel, ohta

__all__ = [
    'FACE_MATCH_DISTANCE',
    'FACE_SKIN_PATCHES',
    'PRIOR_SCALE',
    'FaceSkin',
    'face_skin_class',
    'face_skin_mask',
    'face_skin_model',
    'frame_skin_model',
]

FACE_SKIN_PATCHES: tuple[tuple[float, float, float, float], ...] = (
    (-0.5, 0.5, 0.15, 0.15),  # the person's right cheek
    (0.5, 0.5, 0.15, 0.15),  # left cheek
    (0.0, -0.55, 0.35, 0.12),  # forehead, above the brows
    (0.0, 0.2, 0.08, 0.1),  # bridge of the nose
)
"""Ellipses ``(u, v, half_u, half_v)`` of skin in the face's frame: ``u`` in eye distances along
the line from the person's right eye to their left eye, ``v`` in eye-to-mouth distances from the
eyes' midpoint toward the mouth's. The frame turns, tilts and narrows with the face (a face
turned aside has its eyes closer), so the patches stay on the cheeks."""

# Pixels darker than this I1 (shadow, under-exposure) or brighter (a highlight, a clipped channel)
# carry no reliable chromaticity.
DARKEST = 30.0
BRIGHTEST = 240.0
# Mahalanobis distance of the trimming: 2.45 holds 95 % of a 2-D Gaussian.
TRIM_DISTANCE = 2.45
# Variance added to each of I2, I3: a face's pixels spread less than a hand's, which is turned to
# the light differently and is blurred by its motion; and 8-bit colours are quantised.
VARIANCE_FLOOR = 4.0
# The least pixels of a face's patches that make a class (a face about 25 px wide has ~60).
MIN_FACE_PIXELS = 40
# Mahalanobis distance to a face's class within which colours are that person's skin, before the
# segmentation's ``match_scale`` (1.5): 2.0 x 1.5 = 3.0 holds 99 % of a 2-D Gaussian.
FACE_MATCH_DISTANCE = 2.0
# A face's class whose mean lies further than this many of the general model's match distances
# from it is not skin: a warm light moves skin within it, a blue or green cast beyond it
# (docs/decisions/skin-from-the-face.md).
PRIOR_SCALE = 3.0


def face_skin_mask(shape: tuple[int, int], landmarks: Sequence[Sequence[float]]) -> np.ndarray:
    """``(H, W) bool``: the pixels of :data:`FACE_SKIN_PATCHES` of a face with five landmarks
    (the person's right eye, left eye, nose tip, right and left mouth corners, pixels)."""
    points = np.asarray(landmarks, dtype=np.float64).reshape(5, 2)
    eyes = (points[0] + points[1]) / 2.0
    across = points[1] - points[0]
    down = (points[3] + points[4]) / 2.0 - eyes
    mask = np.zeros(shape, dtype=np.uint8)
    angles = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    for u, v, half_u, half_v in FACE_SKIN_PATCHES:
        ellipse_u = u + half_u * np.cos(angles)
        ellipse_v = v + half_v * np.sin(angles)
        outline = eyes + ellipse_u[:, None] * across + ellipse_v[:, None] * down
        cv2.fillPoly(mask, [np.round(outline).astype(np.int32)], 1)
    return mask.astype(bool)


def face_skin_class(
    image: np.ndarray, landmarks: Sequence[Sequence[float]], max_exposure_gain: float = MAX_EXPOSURE_GAIN
) -> SkinClass | None:
    """The skin class of one face: its patches' (I2, I3), trimmed to a Gaussian's core.

    Args:
        image: ``(H, W, 3) uint8`` BGR frame.
        landmarks: The face's five landmarks in ``image``'s pixels (see :func:`face_skin_mask`).
        max_exposure_gain: The segmentation's exposure normalisation, applied first so that the
            class is read in the colours the segmentation reads
            (:attr:`~human_tracker.vision.cues.skin.SkinParameters.max_exposure_gain`).

    Returns:
        The class (mean, covariance with :data:`VARIANCE_FLOOR` added), or None when fewer than
        :data:`MIN_FACE_PIXELS` usable pixels are left (a small, dark or clipped face).
    """
    mask = face_skin_mask(image.shape[:2], landmarks)
    if np.count_nonzero(mask) < MIN_FACE_PIXELS:
        return None
    image = normalise_exposure(np.ascontiguousarray(image, dtype=np.uint8), max_exposure_gain)
    colours = ohta(image[mask]).astype(np.float64)
    chroma = colours[(colours[:, 0] >= DARKEST) & (colours[:, 0] <= BRIGHTEST), 1:]
    if chroma.shape[0] < MIN_FACE_PIXELS:
        return None
    # A robust start (the median, the spread from the median absolute deviation), then the
    # Gaussian of the pixels within TRIM_DISTANCE of it, twice.
    mean = np.median(chroma, axis=0)
    spread = 1.4826 * np.median(np.abs(chroma - mean), axis=0) + 1.0
    covariance = np.diag(spread**2)
    for _ in range(2):
        kept = SkinClass(mean, covariance).distance(chroma) <= TRIM_DISTANCE
        if np.count_nonzero(kept) < MIN_FACE_PIXELS:
            return None
        mean = chroma[kept].mean(axis=0)
        covariance = np.cov(chroma[kept].T)
    return SkinClass(mean, covariance + VARIANCE_FLOOR * np.eye(2))


def face_skin_model(classes: Sequence[SkinClass], match_distance: float = FACE_MATCH_DISTANCE) -> SkinModel:
    """A skin model of faces' classes, for :func:`~human_tracker.vision.cues.skin.segment_skin`."""
    return SkinModel(tuple(classes), match_distance, {'source': f'{len(classes)} faces'})


def within_prior(found: SkinClass, prior: SkinModel, scale: float = PRIOR_SCALE) -> bool:
    """Whether a face's class is skin by the general model: its mean within ``scale`` of the
    prior's match distances (:data:`PRIOR_SCALE`)."""
    return float(prior.distance(found.mean)) <= prior.match_distance * scale


def frame_skin_model(
    image: np.ndarray,
    faces: Sequence[Sequence[Sequence[float]]],
    prior: SkinModel,
    max_exposure_gain: float = MAX_EXPOSURE_GAIN,
) -> SkinModel:
    """The skin model of one frame on its own: the classes of its faces (five landmarks each)
    that the prior accepts (:data:`PRIOR_SCALE`), or the prior when there are none."""
    classes = []
    for landmarks in faces:
        found = face_skin_class(image, landmarks, max_exposure_gain)
        if found is not None and within_prior(found, prior):
            classes.append(found)
    return face_skin_model(classes) if classes else prior


@dataclass
class FaceSkin:
    """One person's skin colour, learnt from their face over frames and adapting slowly.

    Attributes:
        prior: The general model: a face's class whose mean lies further than
            ``prior_scale`` of its ``match_distance`` from it is refused; with nothing learnt,
            :meth:`model` is the prior.
        match_distance: The person's model's match distance (:data:`FACE_MATCH_DISTANCE`).
        adaptation_rate: Weight of a new face's class in the running class, in (0, 1].
        prior_scale: As :data:`PRIOR_SCALE`.
        max_step: A face's class whose mean lies further than this from the running class (in
            its metric) is refused: skin does not change colour from one look to the next, a
            wrong face or a sudden coloured light does.
        relearn_after: After this many such refusals in a row the running class is learnt
            anew from the next face (the room's light has changed).
        max_exposure_gain: As :func:`face_skin_class`'s.
        learnt: The running class, None until a face was accepted.
        refused: Faces refused by ``max_step`` since the last accepted one.
    """

    prior: SkinModel
    match_distance: float = FACE_MATCH_DISTANCE
    adaptation_rate: float = 0.2
    prior_scale: float = PRIOR_SCALE
    max_step: float = 3.0
    relearn_after: int = 10
    max_exposure_gain: float = MAX_EXPOSURE_GAIN
    learnt: SkinClass | None = field(default=None, init=False)
    refused: int = field(default=0, init=False)

    def observe(self, image: np.ndarray, landmarks: Sequence[Sequence[float]]) -> bool:
        """Learn from one face of the person in ``image``; whether it was accepted."""
        found = face_skin_class(image, landmarks, self.max_exposure_gain)
        if found is None or not within_prior(found, self.prior, self.prior_scale):
            return False
        if self.learnt is not None and float(self.learnt.distance(found.mean)) > self.max_step:
            # A lone jump is a wrong face or a passing light; the same jump look after look is
            # the light that changed: learn the person anew.
            self.refused += 1
            if self.refused < self.relearn_after:
                return False
            self.learnt = None
        self.refused = 0
        if self.learnt is None:
            self.learnt = found
        else:
            rate = self.adaptation_rate
            self.learnt = SkinClass(
                (1 - rate) * self.learnt.mean + rate * found.mean,
                (1 - rate) * self.learnt.covariance + rate * found.covariance,
            )
        return True

    def model(self) -> SkinModel:
        """The person's skin model: their face's class, or the prior before any face was accepted."""
        if self.learnt is None:
            return self.prior
        return face_skin_model((self.learnt,), self.match_distance)
