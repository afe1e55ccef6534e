"""The accuracy comparison's rows: the first run's figures and the precision over every run."""

from __future__ import annotations

from human_tracker.evaluation.accuracy import _row


def test_a_row_gives_the_first_run_and_the_spread_over_runs() -> None:
    truth = [(0.0, 0.0, 10.0, 10.0)] * 4
    hit = [(1.0, 1.0, 10.0, 10.0)] * 4
    away = [(100.0, 100.0, 10.0, 10.0)] * 4
    half = hit[:2] + away[:2]
    row = _row('ours', [(half, 2.0), (hit, 3.0), (away, 4.0)], truth)
    assert row['precision_20px'] == 0.5 and row['ms_per_frame'] == 2.0
    assert row['runs'] == 3
    assert (row['precision_20px_mean'], row['precision_20px_min'], row['precision_20px_max']) == (0.5, 0.0, 1.0)


def test_a_row_with_ids_gives_the_mean_idf1_and_switches() -> None:
    """Two runs on four frames: one id throughout (IDF1 1, no switch); a new id from frame 3
    (IDF1 2 * 2 / (2 * 2 + 2 + 2) = 0.5, one switch)."""
    truth = [(0.0, 0.0, 10.0, 10.0)] * 4
    row = _row('ours', [(truth, 1.0), (truth, 1.0)], truth, ids=[[1, 1, 1, 1], [1, 1, 2, 2]])
    assert row['idf1_mean'] == 0.75 and row['id_switches_mean'] == 0.5
