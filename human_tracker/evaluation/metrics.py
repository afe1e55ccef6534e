"""Tracking-benchmark (OTB) metrics on bounding boxes ``(x, y, w, h)`` in pixels.

Only annotated frames count: a ground-truth box that is None or has zero area is skipped.
A frame where the tracker gave no box counts as a failure (infinite error, zero overlap).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    'Box',
    'centre_errors',
    'normalised_errors',
    'overlaps',
    'precision_at',
    'success_curve',
    'success_auc',
    'summarise',
]

Box = tuple[float, float, float, float]


def _annotated(truth: Sequence[Box | None]) -> np.ndarray:
    return np.array([t is not None and t[2] > 0 and t[3] > 0 for t in truth], dtype=bool)


def _centre_offset(p: Box, t: Box) -> np.ndarray:
    """``(2,)`` pixels from the centre of box ``t`` to that of box ``p``."""
    return np.array([p[0] + p[2] / 2 - t[0] - t[2] / 2, p[1] + p[3] / 2 - t[1] - t[3] / 2])


def centre_errors(predicted: Sequence[Box | None], truth: Sequence[Box | None]) -> np.ndarray:
    """Distance in pixels between box centres on the annotated frames (inf where no prediction)."""
    if len(predicted) != len(truth):
        raise ValueError(f'{len(predicted)} predictions for {len(truth)} ground-truth boxes')
    errors = []
    for p, t in zip(predicted, truth, strict=True):
        if t is None or t[2] <= 0 or t[3] <= 0:
            continue
        if p is None:
            errors.append(np.inf)
            continue
        errors.append(float(np.hypot(*_centre_offset(p, t))))
    return np.array(errors, dtype=np.float64)


def normalised_errors(
    predicted: Sequence[Box | None], covariances: Sequence[np.ndarray | None], truth: Sequence[Box | None]
) -> np.ndarray:
    """Normalised estimation error squared e C⁻¹ e of the box centre on the annotated frames with
    a box and its centre's ``(2, 2)`` covariance C (pixels²): chi-squared with 2 degrees of
    freedom, mean 2, when C is the error's true covariance."""
    values = []
    for p, c, t in zip(predicted, covariances, truth, strict=True):
        if p is None or c is None or t is None or t[2] <= 0 or t[3] <= 0:
            continue
        error = _centre_offset(p, t)
        values.append(float(error @ np.linalg.solve(c, error)))
    return np.array(values, dtype=np.float64)


def overlaps(predicted: Sequence[Box | None], truth: Sequence[Box | None]) -> np.ndarray:
    """Intersection over union of the boxes on the annotated frames (0 where no prediction)."""
    keep = _annotated(truth)
    values = []
    for p, t, k in zip(predicted, truth, keep, strict=True):
        if not k:
            continue
        if p is None:
            values.append(0.0)
            continue
        ix = max(0.0, min(p[0] + p[2], t[0] + t[2]) - max(p[0], t[0]))
        iy = max(0.0, min(p[1] + p[3], t[1] + t[3]) - max(p[1], t[1]))
        inter = ix * iy
        union = p[2] * p[3] + t[2] * t[3] - inter
        values.append(inter / union if union > 0 else 0.0)
    return np.array(values, dtype=np.float64)


def precision_at(errors: np.ndarray, threshold: float = 20.0) -> float:
    """Fraction of annotated frames whose centre error is within ``threshold`` pixels."""
    return float(np.mean(errors <= threshold)) if errors.size else float('nan')


def success_curve(ious: np.ndarray, thresholds: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Fraction of frames with IoU above each threshold (default 0, 0.05, ..., 1)."""
    if thresholds is None:
        thresholds = np.linspace(0.0, 1.0, 21)
    rates = np.array([np.mean(ious > th) if ious.size else np.nan for th in thresholds])
    return thresholds, rates


def success_auc(ious: np.ndarray) -> float:
    """Area under the success curve (the mean of the curve over its 21 thresholds)."""
    return float(np.mean(success_curve(ious)[1]))


def _confident_wrong_share(errors: np.ndarray, truth: Sequence[Box | None]) -> float:
    """Share of the annotated frames where a box is reported (the tracker says TRACKING) but its
    centre is more than twice the true box's width from the true centre: a robot told where a
    person is, wrongly. ``errors`` are :func:`centre_errors` of the same frames."""
    widths = np.array([t[2] for t in truth if t is not None and t[2] > 0 and t[3] > 0], dtype=np.float64)
    if widths.size == 0:
        return 0.0
    return float(np.mean(np.isfinite(errors) & (errors > 2.0 * widths)))


def _falsely_lost_share(
    predicted: Sequence[Box | None], estimated: Sequence[Box | None], truth: Sequence[Box | None]
) -> float:
    """Share of the annotated frames where no box is reported (the tracker does not say TRACKING)
    although the filter's estimate lies within the true box's width of the true centre: a person
    the robot is told is gone, who is followed."""
    keep = _annotated(truth)
    if not keep.any():
        return 0.0
    widths = np.array([t[2] for t, k in zip(truth, keep, strict=True) if k])
    unreported = np.array([p is None for p in predicted])[keep]
    return float(np.mean(unreported & (centre_errors(estimated, truth) <= widths)))


def summarise(
    predicted: Sequence[Box | None], truth: Sequence[Box | None], estimated: Sequence[Box | None] | None = None
) -> dict[str, float]:
    """Precision at 20 px, success AUC, mean centre error, confident-wrong share, the share of
    annotated frames with a reported box (``box_reported``: the person is said to be there,
    rightly or not) and the annotated frame count; with the filter's ``estimated`` boxes on
    every frame (None where it has none), the falsely-lost share too."""
    errors = centre_errors(predicted, truth)
    finite = errors[np.isfinite(errors)]
    extra = {} if estimated is None else {'falsely_lost': round(_falsely_lost_share(predicted, estimated, truth), 4)}
    return {
        **extra,
        'confident_wrong': round(_confident_wrong_share(errors, truth), 4),
        'box_reported': round(float(np.mean(np.isfinite(errors))), 4) if errors.size else 0.0,
        'annotated_frames': int(errors.size),
        'precision_20px': precision_at(errors, 20.0),
        'success_auc': success_auc(overlaps(predicted, truth)),
        'mean_centre_error_px': float(finite.mean()) if finite.size else float('nan'),
    }
