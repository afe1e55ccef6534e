"""Figures of a tracking run: trajectory, centre error over time, precision and success curves."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use('Agg')  # files only: no display on robots and CI
import matplotlib.pyplot as plt
import numpy as np

from human_tracker.evaluation.metrics import Box, centre_errors, overlaps, success_curve

__all__ = ['plot_run']


def _centres(boxes: list[Box | None]) -> np.ndarray:
    return np.array([[np.nan, np.nan] if b is None else [b[0] + b[2] / 2, b[1] + b[3] / 2] for b in boxes])


def plot_run(out: Path, predicted: list[Box | None], truth: list[Box | None], title: str) -> list[Path]:
    """Write ``trajectory.png`` always, and ``error.png``, ``precision.png``, ``success.png`` with ground truth."""
    written = []
    ours, theirs = _centres(predicted), _centres(truth)
    figure, axes = plt.subplots(figsize=(6, 4.5))
    axes.plot(ours[:, 0], ours[:, 1], label='tracker', lw=1.5)
    if any(t is not None for t in truth):
        axes.plot(theirs[:, 0], theirs[:, 1], '.', ms=3, label='ground truth')
    axes.invert_yaxis()
    axes.set(xlabel='x (px)', ylabel='y (px)', title=f'{title}: trajectory of the target centre')
    axes.legend()
    written.append(_save(figure, out / 'trajectory.png'))
    if not any(t is not None for t in truth):
        return written
    frames = [i for i, t in enumerate(truth) if t is not None and t[2] > 0 and t[3] > 0]
    errors = centre_errors(predicted, truth)
    figure, axes = plt.subplots(figsize=(6, 3.5))
    axes.plot(frames, np.where(np.isfinite(errors), errors, np.nan), lw=1)
    axes.axhline(20, color='grey', ls='--', lw=0.8)
    axes.set(xlabel='frame', ylabel='centre error (px)', title=f'{title}: centre error (dashed: 20 px)')
    written.append(_save(figure, out / 'error.png'))
    thresholds = np.arange(0, 51)
    figure, axes = plt.subplots(figsize=(5, 4))
    axes.plot(thresholds, [np.mean(errors <= t) for t in thresholds])
    axes.set(xlabel='location error threshold (px)', ylabel='precision', ylim=(0, 1.02), title=f'{title}: precision')
    written.append(_save(figure, out / 'precision.png'))
    levels, rates = success_curve(overlaps(predicted, truth))
    figure, axes = plt.subplots(figsize=(5, 4))
    axes.plot(levels, rates)
    axes.set(
        xlabel='overlap threshold (IoU)',
        ylabel='success rate',
        ylim=(0, 1.02),
        title=f'{title}: success (AUC {np.mean(rates):.3f})',
    )
    written.append(_save(figure, out / 'success.png'))
    return written


def _save(figure: plt.Figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path
