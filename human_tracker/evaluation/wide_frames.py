"""Small targets in wide frames: real sequences in the middle of frames twice as wide and high.

A robot's 640x480 camera sees a person a few metres away as small as our real sequences'
320x240 frames show them near. Set in a frame twice as wide and high (a grey border round
it), a sequence keeps its target's camera pixels while the default reduction to the working
width makes it twice as small: the case ``min_target_width`` is for
(:meth:`~human_tracker.vision.target.TargetTracker.working_width`). Ours runs with the rule
and without it (``min_target_width`` 0), from the first box and without one.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from human_tracker.io.sequences import read_groundtruth, write_groundtruth
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.target import parameters_for
from human_tracker.vision.tracker import TrackerParameters

__all__ = ['SEQUENCES', 'small_target_rows', 'widen']

# The sequences and their targets: the real hand, the smallest head, and a head already as
# small as the working frame allows once reduced (trellis, 34 working pixels), as a control.
SEQUENCES = {'hand2': 'hand', 'sunshade': 'head', 'trellis': 'head'}
BORDER_GREY = 120


def widen(sequence: Path, out: Path) -> Path:
    """``sequence`` (a folder with ``img/`` and ``groundtruth.txt``) in the middle of frames twice
    as wide and high, written to ``out`` (PNG frames, boxes moved with them); returns ``out``."""
    (out / 'img').mkdir(parents=True, exist_ok=True)
    paths = sorted(p for p in (sequence / 'img').iterdir() if p.is_file())
    dx = dy = 0
    for index, path in enumerate(paths):
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        height, width = image.shape[:2]
        dx, dy = width // 2, height // 2
        wide = cv2.copyMakeBorder(image, dy, dy, dx, dx, cv2.BORDER_CONSTANT, value=(BORDER_GREY,) * 3)
        cv2.imwrite(str(out / 'img' / f'{index:05d}.png'), wide)
    boxes = read_groundtruth(sequence / 'groundtruth.txt')
    write_groundtruth(
        out / 'groundtruth.txt', [None if b is None else (b[0] + dx, b[1] + dy, b[2], b[3]) for b in boxes]
    )
    return out


def small_target_rows(real_data: Path, out: Path, seeds: tuple[int, ...] = (0, 1, 2)) -> list[dict[str, object]]:
    """Precision at 20 px (mean, min, max over ``seeds``) and the worst confident-wrong share of
    ours on each of :data:`SEQUENCES` widened, with ``min_target_width`` and without, from the
    first box and without one; sequences absent from ``real_data`` are skipped."""
    rows = []
    for name, target in SEQUENCES.items():
        if not (real_data / name / 'img').is_dir():
            continue
        folder = widen(real_data / name, out / f'{name}_wide')
        first = read_groundtruth(folder / 'groundtruth.txt')[0]
        for rule in (True, False):
            parameters = parameters_for(target)
            if not rule:
                parameters = replace(parameters, min_target_width=0.0)
            for init in (first, None):
                precision, wrong = [], []
                for seed in seeds:
                    options = TrackOptions(
                        target=target,
                        init=init,
                        target_parameters=parameters,
                        filter_parameters=TrackerParameters(seed=seed),
                        video=False,
                        progress=False,
                    )
                    run = out / f'{name}_wide_runs' / f'{rule}_{init is not None}_{seed}'
                    summary = track_sequence(folder, run, options)
                    precision.append(float(summary['precision_20px']))
                    wrong.append(float(summary['confident_wrong']))
                rows.append(
                    {
                        'sequence': f'{name} widened',
                        'min_target_width': parameters.min_target_width,
                        'start': 'first box' if init is not None else 'none',
                        'runs': len(seeds),
                        'precision_20px_mean': round(float(np.mean(precision)), 3),
                        'precision_20px_min': round(min(precision), 3),
                        'precision_20px_max': round(max(precision), 3),
                        'confident_wrong_max': round(max(wrong), 3),
                    }
                )
    return rows
