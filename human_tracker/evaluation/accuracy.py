"""Accuracy of our tracker and of OpenCV's trackers on the same sequences, same first box.

Every tracker starts on the first annotated frame from its ground-truth box (the OTB
protocol) and is scored on the annotated frames from there on. KCF and CSRT run in the
contrib virtualenv (``contrib_python``) on the same frames written as PNG files.

A particle filter's track depends on its random draws, and on a hard sequence one draw can
hold the target where another loses it. Ours therefore runs with ``SEEDS`` seeds (a hand
with ``HAND_SEEDS``), and MIL, which draws from OpenCV's global generator (each run in a
process gives another track; a fresh process repeats the series), ``RANDOM_BASELINE_RUNS``
times; each row gives the first run's figures and the mean and range of the precision over
the runs.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from human_tracker.evaluation.baselines import run_baseline
from human_tracker.evaluation.facing import LABELS, facing_scores, read_facing, read_labels
from human_tracker.evaluation.identity import identity_scores, one_id_share, one_track
from human_tracker.evaluation.metrics import Box, normalised_errors, summarise
from human_tracker.io.poses import read_covariances, read_ids, read_poses
from human_tracker.io.sequences import open_sequence, write_groundtruth
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.filter.contour_filter import TrackerParameters
from human_tracker.vision.people.persons import kinds_of
from human_tracker.vision.track.parameters import TargetParameters, parameters_for

__all__ = [
    'CONTRIB_BASELINES',
    'MAIN_WHEEL_BASELINES',
    'RANDOM_BASELINE_RUNS',
    'HAND_SEEDS',
    'SEEDS',
    'by_sequence_and_tracker',
    'compare_on_folder',
    'compare_on_sequence',
    'covariance_table',
    'honesty_cell',
    'precision_cell',
    'real_people_table',
    'wrong_cell',
]

MAIN_WHEEL_BASELINES = ('CamShift', 'MIL')
CONTRIB_BASELINES = ('KCF', 'CSRT')
SEEDS = (0, 1, 2, 3, 4)
"""Seeds of our filter's random generator, one run each."""
HAND_SEEDS = tuple(range(10))
"""Seeds of our filter on a hand sequence, one run each: a waving hand's runs differ more from
seed to seed than a head's (docs/decisions/hand-passes-before-its-face.md)."""
RANDOM_BASELINE_RUNS = {'MIL': 3}
"""Runs of the baselines whose result changes from run to run (the others run once)."""
_CHI2_2DOF_95 = 5.991  # 95 % quantile of the chi-squared distribution with 2 degrees of freedom
_REPO = Path(__file__).resolve().parents[2]


def by_sequence_and_tracker(rows: list[dict[str, object]]) -> dict[str, dict[str, dict[str, object]]]:
    """The accuracy rows of the real sequences (those run without a box too), by sequence and
    by tracker: ``ours``, ``ours, no box``, ``paper``, ``person``, ``person, no box`` or the
    baseline's name; hands last."""
    table: dict[str, dict[str, dict[str, object]]] = {}
    for row in rows:
        tracker = str(row['tracker'])
        kind = tracker.split(' (')[0]
        table.setdefault(str(row['sequence']), {})[f'{kind}, no box' if 'no box' in tracker else kind] = row
    real = {name: by for name, by in table.items() if 'ours, no box' in by}
    return dict(sorted(real.items(), key=lambda item: ('hand' in item[0], item[0])))


def precision_cell(row: dict[str, object] | None, spread: bool = True) -> str:
    """Mean precision at 20 px over the runs, with [min, max] when they differ (``spread``)."""
    if row is None:
        return '-'
    mean, low, high = (float(row[f'precision_20px_{k}']) for k in ('mean', 'min', 'max'))
    return f'{mean:.3f} [{low:.3f}, {high:.3f}]' if spread and low != high else f'{mean:.3f}'


def wrong_cell(row: dict[str, object], key: str = 'confident_wrong_max') -> str:
    """The worst run's confident-wrong share (or another share: ``key``)."""
    return f'{float(row[key]):.3f}'.rstrip('0').rstrip('.')


def honesty_cell(row: dict[str, object]) -> str:
    """The worst run's confident-wrong and falsely lost shares and share of annotated frames with
    a reported box (``-``: not measured)."""
    falsely = wrong_cell(row, 'falsely_lost_max') if 'falsely_lost_max' in row else '-'
    reported = f'{float(row["box_reported_min"]):.3f}' if 'box_reported_min' in row else '-'
    return f'{wrong_cell(row)} / {falsely} / {reported}'


def real_people_table(rows: list[dict[str, object]]) -> str:
    """Markdown table of the sequences run without a box too: ours (from the first box and
    without, with the worst run's confident-wrong and falsely lost shares and share of annotated
    frames with a reported box), the paper's tracker
    and OpenCV's trackers, mean precision at 20 px; for a hand,
    ours following the whole person too (the hand scored; with its mean IDF1 and the worst
    run's share of frames on which the person's head kept one id)."""
    real = by_sequence_and_tracker(rows)
    honesty = 'confident-wrong / falsely lost / box reported, worst run'
    columns = ['from the first box', honesty, 'without a box', honesty]
    columns += ["the paper's tracker, from the box", *MAIN_WHEEL_BASELINES, *CONTRIB_BASELINES]
    columns += ['as a person, from the box', 'as a person, without a box']
    lines = ['| sequence | ' + ' | '.join(columns) + ' |', '|---|' + '---|' * len(columns)]
    for sequence, by in real.items():
        cells = [precision_cell(by['ours']), honesty_cell(by['ours'])]
        cells += [precision_cell(by['ours, no box']), honesty_cell(by['ours, no box'])]
        others = ('paper', *MAIN_WHEEL_BASELINES, *CONTRIB_BASELINES)
        cells += [precision_cell(by.get(name), spread=False) for name in others]
        for name in ('person', 'person, no box'):
            row = by.get(name)
            if row is None:
                cells.append('-')
                continue
            held = f', head under one id {row["head_one_id_min"]:.2f}' if 'head_one_id_min' in row else ''
            cells.append(f'{precision_cell(row)} ({wrong_cell(row)}), IDF1 {row["idf1_mean"]:.2f}{held}')
        lines.append(f'| {sequence} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines) + '\n'


def covariance_table(rows: list[dict[str, object]]) -> str:
    """Markdown table of how well the box centre's covariance matches its errors: ours from the
    first box on every sequence, the normalised estimation error squared over the runs' tracked
    frames (2 expected) and the share of them within the 95 % ellipse (0.95 expected)."""
    lines = ['| sequence | NEES of x, y (2 expected) | within the 95 % ellipse |', '|---|---|---|']
    for row in rows:
        tracker = str(row['tracker'])
        if tracker.startswith('ours (') and 'no box' not in tracker and 'nees_mean' in row:
            lines.append(f'| {row["sequence"]} | {float(row["nees_mean"]):.2f} | {float(row["nees_within_95"]):.2f} |')
    return '\n'.join(lines) + '\n'


def compare_on_folder(folder: str | Path, contrib_python: Path | None) -> Iterator[dict[str, object]]:
    """:func:`compare_on_sequence` on every sequence of ``folder`` (its sub-folders with a
    ``groundtruth.txt``, by name), from the first box and without, with the paper's tracker
    (and, for a hand, ours following the whole person); each row gains the ``sequence`` name. A
    sequence whose name holds ``hand`` is a hand's (``../shared/data/real/hand2``), any other
    a head's unless it says otherwise."""
    for path in sorted(p.parent for p in Path(folder).glob('*/groundtruth.txt')):
        target = 'hand' if 'hand' in path.name else None
        person = target == 'hand'
        for row in compare_on_sequence(path, contrib_python, target, without_box=True, paper=True, person=person):
            yield {'sequence': path.name, **row}


def _contrib(name: str, folder: Path, init: Box, contrib_python: Path) -> tuple[list[Box | None], float, float]:
    result = folder.parent / f'{name}.json'
    # On as many threads as this process gives OpenCV (ours and the main wheel's baselines),
    # the OpenBLAS bundled with the contrib wheel included: its own pool (one thread per core)
    # runs KCF's matrix products on both cores of this machine, 1.2 ms a frame on one core
    # against 1.4-1.6 ms and twice the CPU time.
    threads = cv2.getNumThreads()
    blas = {'OPENBLAS_NUM_THREADS': str(threads)} if threads > 0 else {}
    subprocess.run(
        [str(contrib_python), '-m', 'human_tracker.evaluation.baselines', '--tracker', name, '--frames', str(folder)]
        + ['--init', ','.join(f'{v:g}' for v in init), '--out', str(result), '--threads', str(threads)],
        check=True,
        env={**os.environ, 'PYTHONPATH': str(_REPO), **blas},
    )
    data = json.loads(result.read_text())
    boxes = [None if b is None else tuple(b) for b in data['boxes']]
    return boxes, float(data['ms_per_frame']), float(data['cpu_ms_per_frame'])


def _row(
    tracker: str,
    runs: list[tuple[list[Box | None], float, float]],
    scored: list[Box | None],
    ids: list[list[int]] | None = None,
    covariances: list[list[np.ndarray | None]] | None = None,
    particles: list[list[int]] | None = None,
    falsely_lost: list[float] | None = None,
) -> dict[str, object]:
    """The first run's scores and ms per frame (wall clock and CPU), the precision's mean, min and
    max over ``runs``, the largest confident-wrong share of any run and the smallest share of
    annotated frames with a reported box; with each run's target
    ``ids``, the mean IDF1 and the mean and most identity switches
    (:mod:`~human_tracker.evaluation.identity`);
    with each run's box-centre ``covariances``, the normalised estimation error squared over
    every run's frames (its mean, 2 expected, and the share within the 95 % ellipse); with each
    run's ``particles`` ([least, median, most] per frame), the fewest and most of any run; with
    each run's ``falsely_lost`` share (its ``summary.json``'s), the largest."""
    summaries = [summarise(boxes, scored) for boxes, *_ in runs]
    precisions = [summary['precision_20px'] for summary in summaries]
    consistency = {}
    if covariances is not None:
        nees = np.concatenate(
            [normalised_errors(boxes, run, scored) for (boxes, *_), run in zip(runs, covariances, strict=True)]
        )
        consistency = {
            'nees_mean': round(float(nees.mean()), 2) if nees.size else float('nan'),
            'nees_within_95': round(float(np.mean(nees < _CHI2_2DOF_95)), 3) if nees.size else float('nan'),
        }
    identity = {}
    if ids is not None:
        scores = [
            identity_scores({'truth': scored}, one_track(run_ids, boxes))
            for run_ids, (boxes, *_) in zip(ids, runs, strict=True)
        ]
        identity = {
            'idf1_mean': round(float(np.mean([s['idf1'] for s in scores])), 3),
            'id_switches_mean': round(float(np.mean([s['id_switches'] for s in scores])), 1),
            'id_switches_max': int(max(s['id_switches'] for s in scores)),
        }
    return {
        'tracker': tracker,
        **summaries[0],
        'ms_per_frame': round(runs[0][1], 3),
        'cpu_ms_per_frame': round(runs[0][2], 3),
        'runs': len(runs),
        'precision_20px_mean': round(sum(precisions) / len(precisions), 3),
        'precision_20px_min': round(min(precisions), 3),
        'precision_20px_max': round(max(precisions), 3),
        'confident_wrong_max': max(summary['confident_wrong'] for summary in summaries),
        'box_reported_min': min(summary['box_reported'] for summary in summaries),
        # Ours only: a tracker without an estimate while not TRACKING cannot be falsely lost.
        **({'falsely_lost_max': max(falsely_lost)} if falsely_lost else {}),
        **consistency,
        **identity,
        **(
            {'particles_least': min(run[0] for run in particles), 'particles_most': max(run[-1] for run in particles)}
            if particles
            else {}
        ),
    }


def compare_on_sequence(
    path: str | Path,
    contrib_python: Path | None,
    target: str | None = None,
    without_box: bool = False,
    paper: bool = False,
    person: bool = False,
) -> list[dict[str, object]]:
    """Rows (tracker, first run's precision at 20 px, success AUC, mean error, ms per frame; precision over runs).

    ``target`` overrides what the sequence says it outlines (a folder of frames says
    nothing: head); ``without_box`` adds our tracker started by itself (no first box);
    ``paper`` adds the paper's tracker from the first box (``likelihood: paper``,
    ``proposals: off``, ``compensate_camera`` off, a hand open only: the shape and cue
    likelihoods of eqs. 1-4 and §3.2 alone, on the paper's fixed camera); ``person``
    adds ours following the whole person (head and hand, :mod:`~human_tracker.vision.people.persons`)
    from the target's first box and without one, the target's own track scored.
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
        # Ours on exactly those frames, with their truth: its summary scores what only it knows,
        # the filter's estimate while it does not say TRACKING (falsely lost).
        write_groundtruth(folder / 'groundtruth.txt', scored)
        variants: list[tuple[str, Box | None, TargetParameters | None]] = [('ours', init, None)]
        if without_box:
            variants.append(('ours', None, None))
        if paper:
            settings = replace(parameters_for(target), likelihood='paper', proposals='off', compensate_camera=False)
            variants.append(('paper', init, settings))
        if person:
            variants += [('person', init, None), ('person', None, None)]
        labels = LABELS / f'{Path(path).name}.csv'  # where heads are labelled by where they face
        for name, start, parameters in variants:
            # The target scored: a person's bag is scored on its first track, the head's.
            kind = target if name == 'person' else kinds_of(target)[0]
            ours, ids, covariances, head_ids, facings, particles, falsely = [], [], [], [], [], [], []
            for seed in HAND_SEEDS if target == 'hand' else SEEDS:
                options = TrackOptions(
                    target='person' if name == 'person' else target,
                    init=start,
                    init_kind=target if name == 'person' else None,
                    filter_parameters=TrackerParameters(seed=seed),
                    target_parameters=parameters,
                    # The paper's hand is Fig. 1's open hand alone.
                    template_file='open_hand' if name == 'paper' and target == 'hand' else '',
                    progress=False,
                    video=False,
                )
                summary = track_sequence(folder, Path(scratch) / 'ours', options)
                table = Path(scratch) / 'ours' / 'poses.csv'
                ours.append((read_poses(table, kind), summary['ms_per_frame'], summary['cpu_ms_per_frame']))
                if summary.get('particles'):
                    particles.append(summary['particles'])
                if 'falsely_lost' in summary:
                    falsely.append(float(summary['falsely_lost']))
                tracks = read_ids(table)
                ids.append(tracks[kind])
                if name == 'person' and kind != 'head':
                    head_ids.append(tracks['head'])
                covariances.append(read_covariances(table, kind))
                if labels.is_file():
                    facings.append(read_facing(table, kind, offset=first))
            cues = 'background + skin' if summary['skin'] else 'background cue'
            tracker = f'{name} ({cues}{"" if start else ", no box"})'
            row = _row(tracker, ours, scored, ids, covariances, particles, falsely)
            if head_ids:
                # A person's head beside the hand scored: how long it keeps one id, worst run.
                row['head_one_id_min'] = round(min(one_id_share(run) for run in head_ids), 3)
            if any(word for run in facings for word in run.values()):  # a tracker that says where heads face
                row.update(facing_scores(facings, read_labels(labels)))
            rows.append(row)
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
