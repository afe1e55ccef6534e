"""Skin classes in Ohta's (I2, I3) chromaticity plane (§3.2): learnt from labelled samples and
shipped with the package; the label values."""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numba
import numpy as np

# The labels of :func:`segment_skin`: a cluster the skin classes accept (§3.2), and a part of a
# mixed cluster they accept (``SkinParameters.split_mixed``). Non-zero is skin either way.
SKIN = 255
MIXED_SKIN = 128

_OHTA = np.array([[1 / 3, 1 / 3, 1 / 3], [-1 / 2, 0.0, 1 / 2], [-1 / 4, 1 / 2, -1 / 4]], dtype=np.float32)


def ohta(image: np.ndarray) -> np.ndarray:
    """Ohta's I1 I2 I3 components of a BGR image.

    I1 = (R + G + B) / 3 (intensity), I2 = (R - B) / 2, I3 = (2G - R - B) / 4 (chromaticity).

    Args:
        image: ``(..., 3) uint8`` (or float) pixels in B, G, R order.

    Returns:
        ``(..., 3) float32``: I1 in [0, 255], I2 and I3 in [-127.5, 127.5].
    """
    bgr = np.asarray(image, dtype=np.float32)
    if bgr.shape[-1] != 3:
        raise ValueError(f'expected B, G, R in the last axis, got shape {bgr.shape}')
    # One linear map per pixel (rows: I1, I2, I3; columns: B, G, R).
    return (bgr.reshape(-1, 3) @ _OHTA.T).reshape(bgr.shape)


def has_colour(image: np.ndarray) -> bool:
    """Whether an image carries chromaticity: three channels that are not all equal.

    A grey-level camera's frames converted to BGR have equal channels; no skin can be found
    in them.
    """
    if image.ndim != 3 or image.shape[2] != 3:
        return False
    return not (np.array_equal(image[..., 0], image[..., 1]) and np.array_equal(image[..., 1], image[..., 2]))


@dataclass(frozen=True)
class SkinClass:
    """One learnt skin class: a Gaussian cluster in the (I2, I3) plane.

    Attributes:
        mean: ``(2,)`` mean I2, I3.
        covariance: ``(2, 2)`` covariance of I2, I3 of the class's samples.
    """

    mean: np.ndarray
    covariance: np.ndarray

    @functools.cached_property
    def _inverse(self) -> np.ndarray:
        return np.linalg.inv(self.covariance)

    def distance(self, chroma: np.ndarray) -> np.ndarray:
        """Mahalanobis distance of ``(..., 2)`` (I2, I3) values to the class; shape ``(...)``."""
        delta = np.asarray(chroma, dtype=np.float64) - self.mean
        (a, b), (c, d) = self._inverse
        du, dv = delta[..., 0], delta[..., 1]
        # The 2x2 quadratic form written out: a three-operand einsum took 0.1 ms per class and call.
        return np.sqrt(np.maximum(a * du * du + (b + c) * du * dv + d * dv * dv, 0.0))


@dataclass(frozen=True)
class SkinModel:
    """The learnt skin classes of §3.2.

    Attributes:
        classes: The skin classes.
        match_distance: Mahalanobis distance within which a colour belongs to a class; set
            in training so that a chosen fraction of the skin samples falls within it.
        notes: Where the model comes from and how it scored in training (free text).
    """

    classes: tuple[SkinClass, ...]
    match_distance: float
    notes: dict = field(default_factory=dict, compare=False)

    def distance(self, chroma: np.ndarray) -> np.ndarray:
        """Distance of ``(..., 2)`` (I2, I3) values to the nearest class; shape ``(...)``."""
        return self._nearest(chroma)[0]

    @functools.cached_property
    def distance_table(self) -> np.ndarray:
        """Distance to the nearest class of every (I2, I3) that 8-bit B, G, R can give.

        ``(511, 1021) float32``, indexed by ``(R - B + 255, 2G - R - B + 510)``: I2 and I3 are
        those integers over 2 and 4, so the table is exact for every pixel.
        """
        i2, i3 = np.meshgrid(np.arange(-255, 256) / 2.0, np.arange(-510, 511) / 4.0, indexing='ij')
        return self.distance(np.stack([i2, i3], axis=-1)).astype(np.float32)

    def nearest(self, chroma: np.ndarray) -> np.ndarray:
        """Index of the nearest class for ``(..., 2)`` (I2, I3) values; shape ``(...)``."""
        return self._nearest(chroma)[1]

    def _nearest(self, chroma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance to the nearest class and its index, as :meth:`distance` and :meth:`nearest`."""
        chroma = np.asarray(chroma, dtype=np.float64)
        shape = chroma.shape[:-1]
        # One pass over the values in numba: numpy's per-class arrays took 0.3 ms for the
        # 4,800 cells of a 320x240 frame.
        distances, indices = _nearest_class(np.ascontiguousarray(chroma.reshape(-1, 2)), *self._arrays)
        return distances.reshape(shape), indices.reshape(shape)

    @functools.cached_property
    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The classes' ``(K, 2)`` means and ``(K, 2, 2)`` inverse covariances."""
        return np.array([c.mean for c in self.classes], dtype=np.float64), np.array([c._inverse for c in self.classes])

    def to_json(self) -> str:
        """The model as JSON (the shipped data file's format)."""
        return json.dumps(
            {
                'match_distance': self.match_distance,
                'classes': [
                    {'mean': c.mean.round(4).tolist(), 'covariance': c.covariance.round(4).tolist()}
                    for c in self.classes
                ],
                'notes': self.notes,
            },
            indent=1,
        )

    @classmethod
    def from_json(cls, text: str) -> SkinModel:
        """Parse :meth:`to_json` output.

        Raises:
            ValueError: Malformed JSON, or classes that are not proper Gaussians.
        """
        try:
            spec = json.loads(text)
            classes = tuple(
                SkinClass(np.asarray(c['mean'], dtype=np.float64), np.asarray(c['covariance'], dtype=np.float64))
                for c in spec['classes']
            )
            match_distance = float(spec['match_distance'])
        except (ValueError, KeyError, TypeError) as err:
            raise ValueError(f'malformed skin model: {err}') from err
        if not classes or match_distance <= 0:
            raise ValueError('a skin model needs at least one class and match_distance > 0')
        for c in classes:
            if c.mean.shape != (2,) or c.covariance.shape != (2, 2) or np.any(np.linalg.eigvalsh(c.covariance) <= 0):
                raise ValueError('each skin class needs a (2,) mean and a positive definite (2, 2) covariance')
        return cls(classes, match_distance, dict(spec.get('notes', {})))

    @classmethod
    def load(cls, path: str | Path) -> SkinModel:
        """Load a model file written by ``human_tracker train-skin``.

        Raises:
            ValueError: The file is missing or malformed; the message names it.
        """
        try:
            return cls.from_json(Path(path).read_text())
        except (OSError, ValueError) as err:
            raise ValueError(f'cannot load skin model {path}: {err}') from err


@numba.njit(cache=True, nogil=True)
def _nearest_class(chroma: np.ndarray, means: np.ndarray, inverses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mahalanobis distance of ``(N, 2)`` (I2, I3) values to the nearest of the classes with
    ``(K, 2)`` means and ``(K, 2, 2)`` inverse covariances, and that class's index (the first
    of equals); the arithmetic of :meth:`SkinClass.distance`."""
    count = chroma.shape[0]
    distances = np.empty(count, dtype=np.float64)
    indices = np.empty(count, dtype=np.int64)
    for i in range(count):
        best = np.inf
        index = 0
        for k in range(means.shape[0]):
            du, dv = chroma[i, 0] - means[k, 0], chroma[i, 1] - means[k, 1]
            inverse = inverses[k]
            squared = inverse[0, 0] * du * du + (inverse[0, 1] + inverse[1, 0]) * du * dv + inverse[1, 1] * dv * dv
            distance = np.sqrt(max(squared, 0.0))
            if distance < best:
                best, index = distance, k
        distances[i] = best
        indices[i] = index
    return distances, indices


def default_skin_model() -> SkinModel:
    """The model shipped in the package (trained on the UCI skin samples, see its notes)."""
    return SkinModel.from_json(resources.files('human_tracker.data').joinpath('skin_model.json').read_text())


def train_skin_model(
    bgr: np.ndarray,
    is_skin: np.ndarray,
    *,
    num_classes: int = 4,
    skin_coverage: float = 0.95,
    seed: int = 0,
) -> SkinModel:
    """Learn skin classes from labelled colour samples (the paper's training phase).

    The skin samples' (I2, I3) are split into ``num_classes`` clusters by k-means; each
    class is the Gaussian (mean, covariance) of its cluster. ``match_distance`` is the
    Mahalanobis distance to the nearest class within which ``skin_coverage`` of the skin
    samples fall.

    Args:
        bgr: ``(M, 3)`` sample colours, B, G, R order, 0-255.
        is_skin: ``(M,) bool``, True for skin samples.
        num_classes: Number of skin classes (clusters).
        skin_coverage: Fraction of skin samples the classes must cover, in (0, 1).
        seed: Seed of the k-means initialisation.

    Returns:
        The model; its notes record the sample counts and the fraction of non-skin samples
        that fall within ``match_distance`` (the false-positive rate per pixel).
    """
    is_skin = np.asarray(is_skin, dtype=bool)
    chroma = ohta(np.asarray(bgr, dtype=np.float32))[:, 1:].astype(np.float64)
    skin = chroma[is_skin]
    if skin.shape[0] < 10 * num_classes:
        raise ValueError(f'need at least {10 * num_classes} skin samples, got {skin.shape[0]}')
    if not 0.0 < skin_coverage < 1.0:
        raise ValueError(f'skin_coverage must be in (0, 1), got {skin_coverage}')
    from scipy.cluster.vq import kmeans2  # here: a second's import a node answering --help need not pay

    _, labels = kmeans2(skin, num_classes, minit='++', seed=np.random.default_rng(seed))
    classes = tuple(
        SkinClass(skin[labels == k].mean(axis=0), np.cov(skin[labels == k].T) + np.eye(2))
        for k in range(num_classes)
        if np.count_nonzero(labels == k) > 2
    )
    model = SkinModel(classes, 1.0)
    match_distance = float(np.quantile(model.distance(skin), skin_coverage))
    non_skin = chroma[~is_skin]
    accepted = float(np.mean(model.distance(non_skin) <= match_distance)) if non_skin.size else float('nan')
    notes = {
        'skin_samples': int(skin.shape[0]),
        'non_skin_samples': int(non_skin.shape[0]),
        'skin_coverage': skin_coverage,
        'non_skin_accepted': round(accepted, 4),
    }
    return SkinModel(classes, match_distance, notes)
