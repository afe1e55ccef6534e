"""make bench's acceptance table: the issues' bars applied to a run's figures."""

from __future__ import annotations

from pathlib import Path

import pytest

from human_tracker.bench import _readme_summary, write_between_markers
from human_tracker.evaluation.acceptance import acceptance_rows
from human_tracker.evaluation.accuracy import covariance_table, real_people_table


def test_bars_are_applied_to_the_measured_figures() -> None:
    results = {
        'speed': {
            'stages_ms': {
                '640x480': {
                    'particle_filter_500': 0.8,
                    'pipeline': 4.0,
                    'pipeline_cpu': 5.5,
                    'hand_pipeline': 7.0,
                    'hand_pipeline_cpu': 7.5,
                    'person_pipeline': 9.0,
                }
            },
            'trackers_ms_640x480': {'ours (background cue)': 3.0, 'KCF': 2.0, 'CSRT': 25.0},
            'trackers_cpu_ms_640x480': {'ours (background cue)': 3.5, 'KCF': 3.0, 'CSRT': 25.0},
        },
        'accuracy': [
            {'sequence': 'a', 'tracker': 'ours (background cue)', 'precision_20px': 0.97, 'precision_20px_mean': 0.9},
            {'sequence': 'a', 'tracker': 'MIL', 'precision_20px': 0.8, 'precision_20px_mean': 0.95},
            {'sequence': 'a', 'tracker': 'KCF', 'precision_20px': 0.5},
            {'sequence': 'b', 'tracker': 'ours (background + skin)', 'precision_20px': 0.9},
            {'sequence': 'b', 'tracker': 'CamShift', 'precision_20px': 0.9},
            # The NEES bar is the head bags': a real head's is reported, not checked.
            {'sequence': 'head_a', 'tracker': 'ours (background cue)', 'precision_20px': 1.0, 'nees_mean': 0.8},
            {'sequence': 'head_b', 'tracker': 'ours (background cue)', 'precision_20px': 1.0, 'nees_mean': 1.7},
            {
                'sequence': 'trellis',
                'tracker': 'ours (background cue)',
                'precision_20px': 0.7,
                'confident_wrong': 0.1,
                'nees_mean': 5.0,
            },
            {
                'sequence': 'trellis',
                'tracker': 'ours (background cue, no box)',
                'precision_20px': 0.5,
                'confident_wrong': 0.0,
                'confident_wrong_max': 0.08,  # the worst run counts, not the first
                'falsely_lost_max': 0.06,
                'box_reported_min': 0.9,
            },
            {'sequence': 'trellis', 'tracker': 'CSRT', 'precision_20px': 0.6},
            {'sequence': 'hand2', 'tracker': 'ours (background + skin)', 'precision_20px': 0.3},
            {'sequence': 'hand2', 'tracker': 'ours (background + skin, no box)', 'precision_20px': 0.35},
            {'sequence': 'hand2', 'tracker': 'CSRT', 'precision_20px': 0.2},
            {
                'sequence': 'hand2',
                'tracker': 'person (background + skin, no box)',
                'precision_20px': 0.4,
                'confident_wrong_max': 0.07,
                'head_one_id_min': 0.85,
                'idf1_mean': 0.7,
                'id_switches_max': 1,
            },
        ],
        'skin': [
            {'sequence': 'hgr', 'method': 'cells', 'precision': 0.9, 'recall': 0.8, 'f1': 0.85},
            {'sequence': 'hgr', 'method': 'pixels', 'precision': 0.85, 'recall': 0.91, 'f1': 0.88},
            {'sequence': 'x', 'method': 'cells', 'recall': 0.1},
        ],
        'people': [  # seed by seed: the worst seed and track count, not the mean
            {'seed': 0, 'person_1/head': 1.0, 'person_1/hand': 0.95, 'idf1': 0.95, 'id_switches': 0},
            {'seed': 1, 'person_1/head': 0.99, 'person_1/hand': 0.7, 'idf1': 0.88, 'id_switches': 1},
        ],
        'real_people': [{'seed': 0, 'person_1/head': 0.2, 'person_2/head': 1.0, 'idf1': 0.66, 'id_switches': 0}],
        'latency': [
            {
                'layout': 'pipeline',
                'rate': '30 Hz',
                'frames_sent': 240,
                'poses_received': 240,
                'latency_ms_median': 9.0,
                'latency_ms_p95': 18.0,
                'above_processing_ms': 0.8,
            },
            {'layout': 'pipeline', 'rate': 'full speed', 'frames_sent': 240, 'poses_received': 200},  # no bar
            {
                'layout': 'pipeline',
                'rate': '30 Hz',
                'busy_processes': 2,
                'frames_sent': 240,
                'poses_received': 240,
                'latency_ms_median': 11.0,
                'latency_ms_p95': 35.0,
                'above_processing_ms': 1.5,
            },
            {
                'layout': 'separate',
                'rate': '30 Hz',
                'frames_sent': 240,
                'poses_received': 239,
                'latency_ms_median': 4.0,
                'latency_ms_p95': 12.0,
                'above_processing_ms': 2.0,
            },
        ],
    }
    verdicts = {row['check']: (row['measured'], row['bar'], row['met']) for row in acceptance_rows(results)}
    assert verdicts == {
        'particle filter step, 500 particles (ms) <= 1': (0.8, 1.0, True),
        'head pipeline (ms) <= CSRT / 5': (4.0, 5.0, True),
        'hand pipeline (ms) <= 3 KCF': (7.0, 6.0, False),
        'head pipeline, CPU of every thread (ms) <= CSRT / 5': (5.5, 5.0, False),
        'hand pipeline, CPU of every thread (ms) <= 3 KCF': (7.5, 9.0, True),
        'head pipeline (ms) <= KCF': (4.0, 2.0, False),
        'head pipeline, CPU of every thread (ms) <= KCF': (5.5, 3.0, False),
        'hand pipeline (ms) <= 1.5 KCF': (7.0, 3.0, False),
        'person pipeline, head and two hands (ms) <= 2 KCF': (9.0, 4.0, False),
        'person pipeline, head and two hands (ms) <= 2.5 head pipeline': (9.0, 10.0, True),
        'a: mean precision at 20 px >= CamShift, MIL, KCF': (0.9, 0.95, False),
        'b: mean precision at 20 px >= CamShift, MIL, KCF': (0.9, 0.9, True),
        'head_a: mean precision at 20 px >= CamShift, MIL, KCF': (1.0, 0.0, True),
        'head_b: mean precision at 20 px >= CamShift, MIL, KCF': (1.0, 0.0, True),
        'trellis: mean precision at 20 px >= CamShift, MIL, KCF': (0.7, 0.0, True),
        'trellis: without a box >= 0.8 of with one': (0.5, 0.56, False),
        'hand2: mean precision at 20 px >= CamShift, MIL, KCF': (0.3, 0.0, True),
        'head sequences where ours >= CSRT (of 6)': (1, 4, False),
        'hand2: mean precision at 20 px >= 0.6': (0.3, 0.6, False),
        'trellis: from the first box >= CSRT': (0.7, 0.6, True),
        'trellis: without a box >= 0.9 CSRT': (0.5, 0.54, False),
        'hand2: mean precision at 20 px >= CSRT': (0.3, 0.2, True),
        'hand2: mean precision at 20 px >= 0.65': (0.3, 0.65, False),
        'hand2: from the box >= without one': (0.3, 0.35, False),
        'a (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'b (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'head_a (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'head_b (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'trellis (ours): confident-wrong share, worst run <= 0.05': (0.1, 0.05, False),
        'trellis (ours, no box): confident-wrong share, worst run <= 0.05': (0.08, 0.05, False),
        'hand2 (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'hand2 (ours, no box): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'trellis (ours, no box): falsely lost share, worst run <= 0.05': (0.06, 0.05, False),
        'trellis (ours, no box): annotated frames with a reported box, worst run >= 0.95': (0.9, 0.95, False),
        'hand2 (person, no box): confident-wrong share, worst run <= 0.05': (0.07, 0.05, False),
        'hand2 (person, no box): the head keeps one id, share of frames, worst run >= 0.9': (0.85, 0.9, False),
        "hand2 (person, no box): the hand's IDF1, mean >= 0.8": (0.7, 0.8, False),
        'hand2 (person, no box): identity switches of the hand, worst run <= 1': (1, 1, True),
        'head_a: pose NEES of x, y within a factor 2 of 2': (0.8, (1.0, 4.0), False),
        'head_b: pose NEES of x, y within a factor 2 of 2': (1.7, (1.0, 4.0), True),
        'hgr, cells: skin F1 >= 0.92': (0.85, 0.92, False),
        'hgr, cells: skin recall >= 0.9': (0.8, 0.9, False),
        'hgr, pixels: skin F1 >= 0.92': (0.88, 0.92, False),
        'hgr, pixels: skin recall >= 0.9': (0.91, 0.9, True),
        "people_crossing, two people, the replay's seed (0): every track's precision at 20 px >= 0.9": (
            0.95,
            0.9,
            True,
        ),
        "people_crossing, two people, the replay's seed (0): identity switches <= 0": (0, 0, True),
        "people_crossing, two people, the replay's seed (0): IDF1 >= 0.9": (0.95, 0.9, True),
        "people_crossing, two people, 2 seeds (beyond the bar): every track's precision at 20 px, worst seed >= 0.9": (
            0.7,
            0.9,
            False,
        ),
        'people_crossing, two people, 2 seeds (beyond the bar): seeds with an identity switch <= 0': (1, 0, False),
        'people_crossing, two people, 2 seeds (beyond the bar): IDF1, worst seed >= 0.9': (0.88, 0.9, False),
        'two real people side by side, seed 0: IDF1 >= 0.9': (0.66, 0.9, False),
        'latency, pipeline, 30 Hz: poses received of 240 sent': (240, 240, True),
        'latency, pipeline, 30 Hz: median above processing (ms) <= 1': (0.8, 1.0, True),
        'latency, pipeline, 30 Hz, 2 busy processes: poses received of 240 sent': (240, 240, True),
        'latency, pipeline, 30 Hz, 2 busy processes: median above processing (ms) <= 2': (1.5, 2.0, True),
        'latency, pipeline, 30 Hz, 2 busy processes: p95 (ms) < 33': (35.0, 33.0, False),
        'latency, separate, 30 Hz: poses received of 240 sent': (239, 240, False),
        'latency, separate, 30 Hz: median (ms) <= 5': (4.0, 5.0, True),
        'latency, separate, 30 Hz: p95 (ms) <= 10': (12.0, 10.0, False),
    }
    assert acceptance_rows({}) == []


def _scores(sequence: str, tracker: str, mean: float, low: float, high: float, wrong: float = 0.0) -> dict[str, object]:
    return {
        'sequence': sequence,
        'tracker': tracker,
        'precision_20px_mean': mean,
        'precision_20px_min': low,
        'precision_20px_max': high,
        'confident_wrong_max': wrong,
    }


def test_the_summaries_of_real_people_come_from_the_run(tmp_path: Path) -> None:
    """The README's and docs/evaluation.md's tables hold the run's figures, heads before hands,
    real sequences only (a bag has no run without a box), written between their markers."""
    results = {
        'accuracy': [
            {**_scores('head_basic', 'ours (background cue)', 1.0, 1.0, 1.0), 'nees_mean': 1.7, 'nees_within_95': 0.95},
            _scores('hand2', 'ours (background + skin)', 0.4, 0.3, 0.5, 0.06),
            _scores('hand2', 'ours (background + skin, no box)', 0.35, 0.2, 0.45),
            _scores('hand2', 'paper (background + skin)', 0.2, 0.1, 0.3),
            _scores('hand2', 'CSRT', 0.206, 0.206, 0.206),
            {**_scores('hand2', 'person (background + skin)', 0.45, 0.4, 0.5, 0.04), 'idf1_mean': 0.123},
            {
                **_scores('hand2', 'person (background + skin, no box)', 0.4, 0.4, 0.4, 0.03),
                'idf1_mean': 0.2,
                'head_one_id_min': 0.978,
            },
            {
                **_scores('trellis', 'ours (background cue)', 0.9, 0.8, 1.0),
                'falsely_lost_max': 0.012,
                'box_reported_min': 0.97,
            },
            {
                **_scores('trellis', 'ours (background cue, no box)', 0.75, 0.75, 0.75, 0.037),
                'nees_mean': 9.0,  # the covariance table is of the runs from the box
                'nees_within_95': 0.5,
            },
            _scores('trellis', 'paper (background cue)', 0.05, 0.0, 0.1),
            _scores('trellis', 'KCF', 0.026, 0.026, 0.026),
            _scores('trellis', 'CSRT', 1.0, 1.0, 1.0),
        ],
        'speed': {
            'stages_ms': {
                '640x480': {
                    'particle_filter_500': 0.95,
                    'pipeline': 5.0,
                    'pipeline_cpu': 6.25,
                    'hand_pipeline': 9.0,
                    'hand_pipeline_cpu': 10.0,
                }
            },
            'trackers_ms_640x480': {'KCF': 3.0, 'CSRT': 25.0},
            'trackers_cpu_ms_640x480': {'KCF': 4.0, 'CSRT': 25.0},
            'opencv_threads': 1,
        },
    }
    assert _readme_summary(results).splitlines() == [
        '| | trellis | hand2 |',
        '|---|---|---|',
        '| ours | 0.900 (0) | 0.400 (0.06) |',
        '| ours, no box | 0.750 (0.037) | 0.350 (0) |',
        '| CSRT | 1.000 | 0.206 |',
        '',
        'Speed in the same run, 640x480: the head pipeline 5.0 ms per frame, 5.0x faster than CSRT (25.0 ms); '
        'the hand pipeline 9.0 ms, 3.0x KCF (3.0 ms); in CPU time of every thread (the face detector has its own), '
        '4.0x less than CSRT and 2.5x KCF; one particle filter step with 500 particles 0.95 ms. Every tracker ran '
        'OpenCV on 1 thread.',
    ]
    table = real_people_table(results['accuracy']).splitlines()
    assert table[2:] == [
        '| trellis | 0.900 [0.800, 1.000] | 0 / 0.012 / 0.970 | 0.750 | 0.037 / - / - | 0.050 | - | - | 0.026 | 1.000 '
        '| - | - |',
        '| hand2 | 0.400 [0.300, 0.500] | 0.06 / - / - | 0.350 [0.200, 0.450] | 0 / - / - | 0.200 | - | - | - | 0.206 '
        '| 0.450 [0.400, 0.500] (0.04), IDF1 0.12 | 0.400 (0.03), IDF1 0.20, head under one id 0.98 |',
    ]
    assert covariance_table(results['accuracy']).splitlines()[2:] == ['| head_basic | 1.70 | 0.95 |']
    document = tmp_path / 'README.md'
    document.write_text('# x\n<!-- bench:real -->\nold\n<!-- /bench:real -->\n\nafter\n')
    write_between_markers(document, 'real', 'new\n')
    assert document.read_text() == '# x\n<!-- bench:real -->\n\nnew\n\n<!-- /bench:real -->\n\nafter\n'
    with pytest.raises(ValueError, match='no <!-- bench:summary -->'):
        write_between_markers(document, 'summary', 'new\n')
