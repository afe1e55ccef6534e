"""Accuracy of our tracker and of OpenCV's trackers on the same sequences, same first box.

Every tracker starts on the first annotated frame from its ground-truth box (the OTB
protocol) and is scored on the annotated frames from there on. KCF and CSRT run in the
contrib virtualenv (``contrib_python``) on the same frames written as PNG files.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from pathlib import Path

import cv2

from human_tracker.evaluation.baselines import run_baseline
from human_tracker.evaluation.metrics import Box, summarise
from human_tracker.io.sequences import open_sequence
from human_tracker.offline import TrackOptions, read_poses, track_sequence

__all__ = ['MAIN_WHEEL_BASELINES', 'CONTRIB_BASELINES', 'compare_on_sequence']

MAIN_WHEEL_BASELINES = ('CamShift', 'MIL')
CONTRIB_BASELINES = ('KCF', 'CSRT')
_REPO = Path(__file__).resolve().parents[2]


def _contrib(name: str, folder: Path, init: Box, contrib_python: Path) -> tuple[list[Box | None], float]:
    result = folder.parent / f'{name}.json'
    subprocess.run(
        [str(contrib_python), '-m', 'human_tracker.evaluation.baselines', '--tracker', name, '--frames', str(folder)]
        + ['--init', ','.join(f'{v:g}' for v in init), '--out', str(result)],
        check=True,
        env={**os.environ, 'PYTHONPATH': str(_REPO)},
    )
    data = json.loads(result.read_text())
    return [None if b is None else tuple(b) for b in data['boxes']], float(data['ms_per_frame'])


def compare_on_sequence(path: str | Path, contrib_python: Path | None) -> list[dict[str, object]]:
    """Rows (tracker, precision at 20 px, success AUC, mean error, ms per frame) for one sequence."""
    sequence = open_sequence(path)
    target = sequence.target or 'head'
    frames = list(sequence)
    unreadable = [f.index for f in frames if f.image is None]
    if unreadable:
        raise ValueError(f'{path}: frames {unreadable[:5]} cannot be read; the comparison needs every frame')
    truth = [f.ground_truth for f in frames]
    first = next(i for i, t in enumerate(truth) if t is not None)
    init = truth[first]
    scored = truth[first:]
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / 'frames'
        folder.mkdir()
        for index, frame in enumerate(frames[first:]):
            cv2.imwrite(str(folder / f'{index:06d}.png'), frame.image)
        # Ours on exactly those frames (a folder without ground truth: scored here).
        options = TrackOptions(target=target, init=init, progress=False, video=False)
        summary = track_sequence(folder, Path(scratch) / 'ours', options)
        ours = read_poses(Path(scratch) / 'ours' / 'poses.csv')
        rows.append(
            {
                'tracker': 'ours (background + skin)' if summary['skin'] else 'ours (background cue)',
                **summarise(ours, scored),
                'ms_per_frame': summary['ms_per_frame'],
            }
        )
        for name in MAIN_WHEEL_BASELINES:
            boxes, ms = run_baseline(name, (f.image for f in frames[first:]), init)
            rows.append({'tracker': name, **summarise(boxes, scored), 'ms_per_frame': round(ms, 3)})
        if contrib_python is not None:
            for name in CONTRIB_BASELINES:
                boxes, ms = _contrib(name, folder, init, contrib_python)
                rows.append({'tracker': name, **summarise(boxes, scored), 'ms_per_frame': round(ms, 3)})
    return rows
