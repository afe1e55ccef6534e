"""Accuracy of our tracker and of OpenCV's trackers on the same sequences, same first box.

Every tracker starts on the first annotated frame from its ground-truth box (the OTB
protocol) and is scored on the annotated frames from there on. KCF and CSRT run in the
contrib virtualenv (``contrib_python``) on the same frames written as PNG files.

A particle filter's track depends on its random draws, and on a hard sequence one draw can
hold the target where another loses it. Ours therefore runs with ``SEEDS`` seeds, and MIL,
which draws from OpenCV's global generator (each run in a process gives another track; a
fresh process repeats the series), ``RANDOM_BASELINE_RUNS`` times; each row gives the first
run's figures and the mean and range of the precision over the runs.
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
from human_tracker.vision.tracker import TrackerParameters

__all__ = ['CONTRIB_BASELINES', 'MAIN_WHEEL_BASELINES', 'RANDOM_BASELINE_RUNS', 'SEEDS', 'compare_on_sequence']

MAIN_WHEEL_BASELINES = ('CamShift', 'MIL')
CONTRIB_BASELINES = ('KCF', 'CSRT')
SEEDS = (0, 1, 2, 3, 4)
"""Seeds of our filter's random generator, one run each."""
RANDOM_BASELINE_RUNS = {'MIL': 3}
"""Runs of the baselines whose result changes from run to run (the others run once)."""
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


def _row(tracker: str, runs: list[tuple[list[Box | None], float]], scored: list[Box | None]) -> dict[str, object]:
    """The first run's scores and ms per frame, the precision's mean, min and max over ``runs``, and
    the largest confident-wrong share of any run."""
    summaries = [summarise(boxes, scored) for boxes, _ in runs]
    precisions = [summary['precision_20px'] for summary in summaries]
    return {
        'tracker': tracker,
        **summaries[0],
        'ms_per_frame': round(runs[0][1], 3),
        'runs': len(runs),
        'precision_20px_mean': round(sum(precisions) / len(precisions), 3),
        'precision_20px_min': round(min(precisions), 3),
        'precision_20px_max': round(max(precisions), 3),
        'confident_wrong_max': max(summary['confident_wrong'] for summary in summaries),
    }


def compare_on_sequence(
    path: str | Path, contrib_python: Path | None, target: str | None = None, without_box: bool = False
) -> list[dict[str, object]]:
    """Rows (tracker, first run's precision at 20 px, success AUC, mean error, ms per frame; precision over runs).

    ``target`` overrides what the sequence says it outlines (a folder of frames says
    nothing: head); ``without_box`` adds our tracker started by itself (no first box).
    """
    sequence = open_sequence(path)
    target = target or sequence.target or 'head'
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
        for start in (init, None) if without_box else (init,):
            ours = []
            for seed in SEEDS:
                options = TrackOptions(
                    target=target,
                    init=start,
                    filter_parameters=TrackerParameters(seed=seed),
                    progress=False,
                    video=False,
                )
                summary = track_sequence(folder, Path(scratch) / 'ours', options)
                ours.append((read_poses(Path(scratch) / 'ours' / 'poses.csv'), float(summary['ms_per_frame'])))
            cues = 'background + skin' if summary['skin'] else 'background cue'
            rows.append(_row(f'ours ({cues}{"" if start else ", no box"})', ours, scored))
        for name in MAIN_WHEEL_BASELINES:
            runs = [
                run_baseline(name, (f.image for f in frames[first:]), init)
                for _ in range(RANDOM_BASELINE_RUNS.get(name, 1))
            ]
            rows.append(_row(name, runs, scored))
        if contrib_python is not None:
            for name in CONTRIB_BASELINES:
                runs = [_contrib(name, folder, init, contrib_python) for _ in range(RANDOM_BASELINE_RUNS.get(name, 1))]
                rows.append(_row(name, runs, scored))
    return rows
