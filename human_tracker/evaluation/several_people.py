"""Several people in one scene, seed by seed: every ground-truth track and the identities.

The real sequences hold one person each. Two situations they lack: the two-person bag
(``people_crossing``: one person waves beside the other, who walks across in front), and two
real people side by side, made by :func:`side_by_side` from two real sequences (each scaled to
one height, trimmed to the shorter, with its own ground truth). Each seed is one run of
``track --target person --max-people 2``; a row per seed shows every track's
precision at 20 px (against the followed target of its kind that matches it best) and every
target against every track (MOTA, IDF1, identity switches: :mod:`~human_tracker.evaluation.identity`).
Rows, not a mean: a robot runs one seed, and a bad seed is a person lost.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np

from human_tracker.io.bags import write_bag
from human_tracker.io.sequences import open_sequence
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.filter.contour_filter import TrackerParameters

__all__ = ['REAL_PAIR', 'side_by_side', 'two_people_rows']

REAL_PAIR = ('seated_agbani', 'interview_alberto')
"""Two real sequences of a seated person, head and shoulders, that :func:`side_by_side` joins."""


def side_by_side(left: Path, right: Path, out: Path, height: int = 240) -> Path | None:
    """A bag of two real people: the frames of ``left`` and ``right`` each scaled to ``height``
    pixels and set side by side, as many as the shorter has, stamped 30 a second; the ground
    truth of each (scaled, the right one shifted) on its own track, ``person_1/head`` (left)
    and ``person_2/head``. None when either is absent; ``out`` reused when it exists."""
    if not (left.is_dir() and right.is_dir()):
        return None
    if (out / 'metadata.yaml').exists():
        return out
    frames = []
    for a, b in zip(open_sequence(left), open_sequence(right), strict=False):
        if a.image is None or b.image is None:
            continue
        scales = [height / frame.image.shape[0] for frame in (a, b)]
        images = [
            cv2.resize(f.image, None, fx=k, fy=k, interpolation=cv2.INTER_AREA)
            for f, k in zip((a, b), scales, strict=True)
        ]
        offset = images[0].shape[1]
        boxes = {}
        for name, frame, k, dx in (('person_1/head', a, scales[0], 0), ('person_2/head', b, scales[1], offset)):
            box = frame.ground_truth
            boxes[name] = None if box is None else (box[0] * k + dx, box[1] * k, box[2] * k, box[3] * k)
        frames.append((len(frames) * 33_333_333, np.hstack([images[0], images[1][:height]]), boxes))
    out.parent.mkdir(parents=True, exist_ok=True)
    return write_bag(out, frames, target='person')


def two_people_rows(bag: Path, out: Path, seeds: Iterable[int] = range(10)) -> list[dict[str, object]]:
    """One row per seed of two people followed in ``bag`` (each run written under ``out``):
    the seed, each ground-truth track's precision at 20 px, MOTA, IDF1 and identity switches.
    Empty when ``bag`` is absent."""
    if not bag.is_dir():
        return []
    rows: list[dict[str, object]] = []
    for seed in seeds:
        options = TrackOptions(
            target='person',
            max_people=2,
            filter_parameters=TrackerParameters(seed=seed),
            video=False,
            progress=False,
        )
        summary = track_sequence(bag, out / f'seed_{seed}', options)
        tracks = {name: round(float(score['precision_20px']), 3) for name, score in summary['tracks'].items()}
        identity = summary['all_tracks']
        rows.append(
            {
                'seed': seed,
                **tracks,
                'mota': round(float(identity['mota']), 3),
                'idf1': round(float(identity['idf1']), 3),
                'id_switches': int(identity['id_switches']),
            }
        )
    return rows
