"""The accuracy comparison's rows: the first run's figures and the precision over every run."""

from __future__ import annotations

import numpy as np

from human_tracker.evaluation.accuracy import _row


def test_a_row_gives_the_first_run_and_the_spread_over_runs() -> None:
    truth = [(0.0, 0.0, 10.0, 10.0)] * 4
    hit = [(1.0, 1.0, 10.0, 10.0)] * 4
    away = [(100.0, 100.0, 10.0, 10.0)] * 4
    half = hit[:2] + away[:2]
    row = _row('ours', [(half, 2.0, 2.5), (hit, 3.0, 3.5), (away, 4.0, 4.5)], truth)
    assert row['precision_20px'] == 0.5 and (row['ms_per_frame'], row['cpu_ms_per_frame']) == (2.0, 2.5)
    assert row['runs'] == 3
    assert (row['precision_20px_mean'], row['precision_20px_min'], row['precision_20px_max']) == (0.5, 0.0, 1.0)


def test_a_row_with_ids_gives_the_mean_idf1_and_switches() -> None:
    """Two runs on four frames: one id throughout (IDF1 1, no switch); a new id from frame 3
    (IDF1 2 * 2 / (2 * 2 + 2 + 2) = 0.5, one switch)."""
    truth = [(0.0, 0.0, 10.0, 10.0)] * 4
    row = _row('ours', [(truth, 1.0, 1.0), (truth, 1.0, 1.0)], truth, ids=[[1, 1, 1, 1], [1, 1, 2, 2]])
    assert row['idf1_mean'] == 0.75 and row['id_switches_mean'] == 0.5


def test_a_row_with_covariances_gives_the_nees_over_every_run() -> None:
    """Centres 1 px off on both axes, unit covariance: e C⁻¹ e = 2 on every frame, well inside
    the 95 % ellipse (5.99); with a covariance of 0.1 px² it is 20, outside. Untracked frames
    (no box) are left out."""
    truth = [(0.0, 0.0, 10.0, 10.0)] * 2
    hit = [(1.0, 1.0, 10.0, 10.0)] * 2
    runs = [(hit, 1.0, 1.0), ([hit[0], None], 1.0, 1.0)]
    row = _row('ours', runs, truth, covariances=[[np.eye(2), 0.1 * np.eye(2)], [np.eye(2), None]])
    assert row['nees_mean'] == round((2 + 20 + 2) / 3, 2) and row['nees_within_95'] == round(2 / 3, 3)


def test_a_row_with_particle_counts_gives_the_fewest_and_most_of_any_run() -> None:
    """Each run's [least, median, most] particles on a frame (KLD-sampling's range in use)."""
    truth = [(0.0, 0.0, 10.0, 10.0)] * 2
    runs = [(truth, 1.0, 1.0), (truth, 1.0, 1.0)]
    row = _row('ours', runs, truth, particles=[[120, 200, 480], [100, 150, 500]])
    assert (row['particles_least'], row['particles_most']) == (100, 500)
    assert 'particles_least' not in _row('ours', runs, truth)
