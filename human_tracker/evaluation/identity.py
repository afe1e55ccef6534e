"""Identity metrics of a followed target against its ground truth: CLEAR MOT's accuracy (MOTA),
IDF1 and identity switches, computed by the ``motmetrics`` library.

A track here is one kind of target (a head, a hand) with an id per frame (0: none, the target
was not followed) and its box. A ground-truth box is matched to a reported one whose centre is
within ``threshold`` pixels of its own (the radius of precision at 20 px). Only annotated frames
count, as in :mod:`~human_tracker.evaluation.metrics`: a sequence annotated on some frames says
nothing of the others. Each time the target is taken up again after being lost it gets a new
id, so a re-acquisition counts as an identity switch, as it does for a robot that keys what it
knows of a person by the id.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from human_tracker.evaluation.metrics import Box

__all__ = ['identity_scores']


def _centre(box: Box) -> np.ndarray:
    return np.array([[box[0] + box[2] / 2.0, box[1] + box[3] / 2.0]])


def identity_scores(
    ids: Sequence[int], boxes: Sequence[Box | None], truth: Sequence[Box | None], threshold: float = 20.0
) -> dict[str, float | int]:
    """MOTA, IDF1 and identity switches of one track against one ground-truth track.

    Args:
        ids: The target's id on each frame (0 where it has none).
        boxes: Its box on each frame, ``(x, y, w, h)`` pixels (None where not reported).
        truth: The true box on each frame (None or zero area where not annotated).
        threshold: Largest centre distance, pixels, at which a reported box matches the truth.

    Returns:
        ``mota`` and ``idf1`` (fractions, rounded to 4 places) and ``id_switches``.
    """
    import motmetrics  # only the evaluation needs it (and its pandas): the nodes do not

    if not len(ids) == len(boxes) == len(truth):
        raise ValueError(f'{len(ids)} ids, {len(boxes)} boxes and {len(truth)} ground-truth boxes')
    frames = motmetrics.MOTAccumulator(auto_id=True)
    for target_id, box, true_box in zip(ids, boxes, truth, strict=True):
        if true_box is None or true_box[2] <= 0 or true_box[3] <= 0:
            continue
        reported = box is not None and target_id > 0
        hypotheses = _centre(box) if reported else np.empty((0, 2))
        distances = motmetrics.distances.norm2squared_matrix(_centre(true_box), hypotheses, max_d2=threshold**2)
        frames.update([1], [target_id] if reported else [], distances)
    scores = motmetrics.metrics.create().compute(frames, metrics=['mota', 'idf1', 'num_switches'])
    return {
        'mota': round(float(scores['mota'].iloc[0]), 4),
        'idf1': round(float(scores['idf1'].iloc[0]), 4),
        'id_switches': int(scores['num_switches'].iloc[0]),
    }
