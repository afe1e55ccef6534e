"""OTB metrics and skin label scores with hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from human_tracker.evaluation.metrics import (
    centre_errors,
    normalised_errors,
    overlaps,
    precision_at,
    success_auc,
    summarise,
)
from human_tracker.evaluation.skin import box_mask, skin_scores


def test_centre_error_iou_and_precision_hand_computed() -> None:
    truth = [(0, 0, 10, 10), (0, 0, 10, 10), None, (0, 0, 0, 0), (0, 0, 10, 10)]
    predicted = [(3, 4, 10, 10), (30, 0, 10, 10), (5, 5, 5, 5), (1, 1, 1, 1), None]
    errors = centre_errors(predicted, truth)
    # Unannotated frames (None, zero box) are skipped; a missing prediction is a failure.
    np.testing.assert_allclose(errors, [5.0, 30.0, np.inf])
    assert precision_at(errors, 20) == pytest.approx(1 / 3)
    # Boxes shifted by (3, 4): intersection 7 * 6 = 42, union 200 - 42 = 158.
    np.testing.assert_allclose(overlaps(predicted, truth), [42 / 158, 0.0, 0.0])


def test_normalised_errors_hand_computed() -> None:
    """e C⁻¹ e of the box centre: (3, 4) px off with variances 9 and 16 gives 1 + 1; with a
    correlation too, the full inverse. Frames without a box, a covariance or a truth are skipped."""
    truth = [(0, 0, 10, 10), (0, 0, 10, 10), (0, 0, 10, 10), None, (0, 0, 10, 10)]
    predicted = [(3, 4, 10, 10), (3, 4, 10, 10), None, (1, 1, 10, 10), (1, 1, 10, 10)]
    correlated = np.array([[2.0, 1.0], [1.0, 2.0]])  # inverse [[2, -1], [-1, 2]] / 3
    covariances = [np.diag([9.0, 16.0]), correlated, np.eye(2), np.eye(2), None]
    np.testing.assert_allclose(normalised_errors(predicted, covariances, truth), [2.0, (18 - 24 + 32) / 3])


def test_success_auc_of_perfect_and_empty_tracks() -> None:
    assert success_auc(np.ones(5)) == pytest.approx(20 / 21)  # IoU 1 passes every threshold but > 1
    assert success_auc(np.zeros(5)) == pytest.approx(0.0)
    summary = summarise([(0, 0, 10, 10)], [(0, 0, 10, 10)])
    assert summary['precision_20px'] == 1.0 and summary['mean_centre_error_px'] == 0.0


def test_skin_scores_by_hand() -> None:
    truth = np.zeros((4, 6), dtype=bool)
    truth[0:2, 0:2] = True  # region 1: 4 pixels
    truth[3, 5] = True  # region 2: 1 pixel
    labels = np.zeros((4, 6), dtype=np.uint8)
    labels[0:2, 1:3] = 255  # 2 hits, 2 false labels; region 2 missed
    scores = skin_scores([labels], [truth])
    assert scores == {
        'precision': 0.5,
        'recall': 0.4,
        'labelled_fraction': round(4 / 24, 4),
        'regions': 2,
        'regions_found': 1,
    }
    np.testing.assert_array_equal(box_mask((3, 3), [[1, 0, 2, 1]]), [[0, 1, 1], [0, 1, 1], [0, 0, 0]])


def test_falsely_lost_counts_unreported_frames_whose_estimate_is_on_the_target() -> None:
    """Four annotated frames (target 20 px wide at centre (50, 50)) and one not annotated:
    reported; not reported with the estimate 15 px off (falsely lost); not reported 25 px off
    (truly lost); not reported and no estimate (WAITING). 1 of 4."""
    truth = [(40.0, 40.0, 20.0, 20.0)] * 4 + [None]
    on, near, far = (40.0, 40.0, 20.0, 20.0), (55.0, 40.0, 20.0, 20.0), (65.0, 40.0, 20.0, 20.0)
    predicted = [on, None, None, None, None]
    estimated = [on, near, far, None, near]
    assert summarise(predicted, truth, estimated)['falsely_lost'] == 0.25
    assert 'falsely_lost' not in summarise(predicted, truth)  # a tracker with no estimate when it says lost
    assert summarise(predicted, truth)['box_reported'] == 0.25  # one annotated frame of four has a box
