"""make bench's acceptance table: the issues' bars applied to a run's figures."""

from __future__ import annotations

from human_tracker.bench import _acceptance


def test_bars_are_applied_to_the_measured_figures() -> None:
    results = {
        'speed': {
            'stages_ms': {'640x480': {'particle_filter_500': 0.8, 'pipeline': 4.0, 'hand_pipeline': 7.0}},
            'trackers_ms_640x480': {'ours (background cue)': 3.0, 'KCF': 2.0, 'CSRT': 25.0},
        },
        'accuracy': [
            {'sequence': 'a', 'tracker': 'ours (background cue)', 'precision_20px': 0.97, 'precision_20px_mean': 0.9},
            {'sequence': 'a', 'tracker': 'MIL', 'precision_20px': 0.8, 'precision_20px_mean': 0.95},
            {'sequence': 'a', 'tracker': 'KCF', 'precision_20px': 0.5},
            {'sequence': 'b', 'tracker': 'ours (background + skin)', 'precision_20px': 0.9},
            {'sequence': 'b', 'tracker': 'CamShift', 'precision_20px': 0.9},
            {'sequence': 'trellis', 'tracker': 'ours (background cue)', 'precision_20px': 0.7, 'confident_wrong': 0.1},
            {
                'sequence': 'trellis',
                'tracker': 'ours (background cue, no box)',
                'precision_20px': 0.5,
                'confident_wrong': 0.0,
                'confident_wrong_max': 0.08,  # the worst run counts, not the first
            },
            {'sequence': 'trellis', 'tracker': 'CSRT', 'precision_20px': 0.6},
            {'sequence': 'hand2', 'tracker': 'ours (background + skin)', 'precision_20px': 0.3},
            {'sequence': 'hand2', 'tracker': 'CSRT', 'precision_20px': 0.2},
        ],
        'skin': [
            {'sequence': 'hgr', 'method': 'cells', 'precision': 0.9, 'recall': 0.8, 'f1': 0.85},
            {'sequence': 'hgr', 'method': 'pixels', 'precision': 0.85, 'recall': 0.91, 'f1': 0.88},
            {'sequence': 'x', 'method': 'cells', 'recall': 0.1},
        ],
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
    verdicts = {row['check']: (row['measured'], row['bar'], row['met']) for row in _acceptance(results)}
    assert verdicts == {
        'particle filter step, 500 particles (ms) <= 1': (0.8, 1.0, True),
        'head pipeline (ms) <= CSRT / 5': (4.0, 5.0, True),
        'hand pipeline (ms) <= 3 KCF': (7.0, 6.0, False),
        'a: mean precision at 20 px >= CamShift, MIL, KCF': (0.9, 0.95, False),
        'b: mean precision at 20 px >= CamShift, MIL, KCF': (0.9, 0.9, True),
        'trellis: mean precision at 20 px >= CamShift, MIL, KCF': (0.7, 0.0, True),
        'trellis: without a box >= 0.8 of with one': (0.5, 0.56, False),
        'hand2: mean precision at 20 px >= CamShift, MIL, KCF': (0.3, 0.0, True),
        'head sequences where ours >= CSRT (of 6)': (1, 4, False),
        'hand2: mean precision at 20 px >= 0.6': (0.3, 0.6, False),
        'hand2: mean precision at 20 px >= CSRT': (0.3, 0.2, True),
        'a (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'b (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'trellis (ours): confident-wrong share, worst run <= 0.05': (0.1, 0.05, False),
        'trellis (ours, no box): confident-wrong share, worst run <= 0.05': (0.08, 0.05, False),
        'hand2 (ours): confident-wrong share, worst run <= 0.05': (0.0, 0.05, True),
        'hgr, cells: skin F1 >= 0.92': (0.85, 0.92, False),
        'hgr, cells: skin recall >= 0.9': (0.8, 0.9, False),
        'hgr, pixels: skin F1 >= 0.92': (0.88, 0.92, False),
        'hgr, pixels: skin recall >= 0.9': (0.91, 0.9, True),
        'latency, pipeline, 30 Hz: poses received of 240 sent': (240, 240, True),
        'latency, pipeline, 30 Hz: median above processing (ms) <= 1': (0.8, 1.0, True),
        'latency, separate, 30 Hz: poses received of 240 sent': (239, 240, False),
        'latency, separate, 30 Hz: median (ms) <= 5': (4.0, 5.0, True),
        'latency, separate, 30 Hz: p95 (ms) <= 10': (12.0, 10.0, False),
    }
    assert _acceptance({}) == []
