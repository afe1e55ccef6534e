"""How well a head's ``facing`` (:mod:`~human_tracker.vision.faces.facing`) matches labels by eye.

The labels are ``test/data/facing/<sequence>.csv``: ``frame,facing`` on every tenth frame of the
real sequences where heads turn, ``toward`` (the face turned to the camera, also when a hand or
a book hides part of it), ``side`` (profile or three-quarter) or ``away`` (the back of the
head). Each class's precision is the share of frames reported so that are labelled so; its
recall, the share of frames labelled so that are reported so. A frame reported ``unknown`` (or
not followed) counts against the recall of its label, not against any precision.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Mapping
from pathlib import Path

from human_tracker.vision.faces.facing import Facing

__all__ = ['CLASSES', 'LABELS', 'facing_scores', 'read_facing', 'read_labels']

LABELS = Path(__file__).resolve().parents[2] / 'test' / 'data' / 'facing'
CLASSES = (Facing.TOWARD, Facing.SIDE, Facing.AWAY)


def read_labels(path: str | Path) -> dict[int, Facing]:
    """The labels of one sequence: frame index -> facing."""
    with Path(path).open(newline='') as handle:
        return {int(row['frame']): Facing(row['facing']) for row in csv.DictReader(handle)}


def read_facing(poses: str | Path, kind: str = 'head', offset: int = 0) -> dict[int, str]:
    """The ``facing`` column of a ``poses.csv`` for the first target of ``kind``: frame index
    (plus ``offset``, where the table starts at a later frame of the sequence) -> word ('' for a
    frame without one)."""
    found: dict[int, str] = {}
    with Path(poses).open(newline='') as handle:
        for row in csv.DictReader(handle):
            if row.get('kind', kind) in (kind, '') and int(row['frame']) + offset not in found:
                found[int(row['frame']) + offset] = row.get('facing', '')
    return found


def facing_scores(runs: Iterable[Mapping[int, str]], labels: Mapping[int, Facing]) -> dict[str, float]:
    """Per class precision and recall, pooled over ``runs`` (each frame -> reported word), and
    the share of labelled frames reported unknown or not at all (``facing_unknown``)."""
    pairs = [
        (label, Facing(run[frame]) if run.get(frame) else Facing.UNKNOWN)
        for run in runs
        for frame, label in labels.items()
    ]
    scores: dict[str, float] = {}
    for name in CLASSES:
        reported = [label for label, said in pairs if said == name]
        labelled = [said for label, said in pairs if label == name]
        if reported:
            scores[f'facing_{name}_precision'] = round(sum(label == name for label in reported) / len(reported), 3)
        if labelled:
            scores[f'facing_{name}_recall'] = round(sum(said == name for said in labelled) / len(labelled), 3)
    if pairs:
        scores['facing_unknown'] = round(sum(said == Facing.UNKNOWN for _, said in pairs) / len(pairs), 3)
    return scores
