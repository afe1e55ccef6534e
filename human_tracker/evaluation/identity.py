"""Identity metrics of followed targets against ground-truth tracks: CLEAR MOT's accuracy (MOTA),
IDF1 and identity switches, computed by the ``motmetrics`` library.

A reported target is an id (from 1) and its box on a frame; a ground-truth track is a name and
its box on each frame. A true box is matched to a reported one whose centre is within
``threshold`` pixels of its own (the radius of precision at 20 px). A frame counts when at
least one track is annotated on it, as in :mod:`~human_tracker.evaluation.metrics`: a sequence
annotated on some frames says nothing of the others. A target taken up again under a new id
(lost for longer than its id is held, or found elsewhere: :mod:`~human_tracker.vision.people.persons`)
counts as an identity switch, as it does for a robot that keys what it knows of a person by
the id.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence

import numpy as np

from human_tracker.evaluation.metrics import Box

__all__ = ['identity_scores', 'one_id_share', 'one_track']


def _centres(boxes: Sequence[Box]) -> np.ndarray:
    return np.array([[b[0] + b[2] / 2.0, b[1] + b[3] / 2.0] for b in boxes]).reshape(-1, 2)


def one_track(ids: Sequence[int], boxes: Sequence[Box | None]) -> list[dict[int, Box]]:
    """Per frame, the target ``{id: box}`` where it has both an id (> 0) and a box, else nothing."""
    if len(ids) != len(boxes):
        raise ValueError(f'{len(ids)} ids for {len(boxes)} boxes')
    return [{i: b} if b is not None and i > 0 else {} for i, b in zip(ids, boxes, strict=True)]


def one_id_share(ids: Sequence[int]) -> float:
    """Share of the frames on which a target is reported under its most frequent id (ids > 0;
    0 where it is not reported): 1 for a target held under one id from the first frame to the
    last, less for each frame it is lost or known under another id."""
    counts = Counter(i for i in ids if i > 0)
    return max(counts.values(), default=0) / len(ids) if ids else 0.0


def identity_scores(
    truth: Mapping[str, Sequence[Box | None]],
    reported: Sequence[Mapping[int, Box]],
    threshold: float = 20.0,
    kinds: Mapping[int, str] | None = None,
) -> dict[str, float | int]:
    """MOTA, IDF1 and identity switches of the ``reported`` targets against the ``truth`` tracks.

    Args:
        truth: Each ground-truth track's box on each frame, by name (None or zero area where not
            annotated, or out of view).
        reported: On each frame, the reported targets' boxes by id (``(x, y, w, h)`` pixels).
        threshold: Largest centre distance, pixels, at which a reported box matches a true one.
        kinds: Each reported id's kind (``head``, ``hand``): it matches only the tracks whose
            name ends in it (``person_1/head``); None: any track.

    Returns:
        ``mota`` and ``idf1`` (fractions, rounded to 4 places) and ``id_switches``.
    """
    import motmetrics  # only the evaluation needs it (and its pandas): the nodes do not

    names = list(truth)
    if any(len(truth[name]) != len(reported) for name in names):
        raise ValueError(f'{len(reported)} frames reported, ground truth of {[len(truth[n]) for n in names]}')
    frames = motmetrics.MOTAccumulator(auto_id=True)
    for index, targets in enumerate(reported):
        present = [
            (k, box)
            for k, name in enumerate(names)
            if (box := truth[name][index]) is not None and box[2] > 0 and box[3] > 0
        ]
        if not present:
            continue
        hypotheses = list(targets.items())
        distances = motmetrics.distances.norm2squared_matrix(
            _centres([box for _, box in present]), _centres([box for _, box in hypotheses]), max_d2=threshold**2
        )
        if kinds is not None:
            for row, (k, _) in enumerate(present):
                for column, (i, _) in enumerate(hypotheses):
                    if names[k].rsplit('/', 1)[-1] != kinds[i]:
                        distances[row, column] = np.nan  # a hand is no head
        frames.update([k for k, _ in present], [i for i, _ in hypotheses], distances)
    scores = motmetrics.metrics.create().compute(frames, metrics=['mota', 'idf1', 'num_switches'])
    return {
        'mota': round(float(scores['mota'].iloc[0]), 4),
        'idf1': round(float(scores['idf1'].iloc[0]), 4),
        'id_switches': int(scores['num_switches'].iloc[0]),
    }
