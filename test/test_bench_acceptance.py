"""make bench's acceptance table: the issue's bars applied to a run's figures."""

from __future__ import annotations

from human_tracker.bench import _acceptance


def test_bars_are_applied_to_the_measured_figures() -> None:
    results = {
        'speed': {
            'stages_ms': {'640x480': {'particle_filter_500': 0.8, 'pipeline': 4.0}},
            'trackers_ms_640x480': {'ours (background cue)': 3.0, 'KCF': 2.0, 'CSRT': 25.0},
        },
        'accuracy': [
            {'sequence': 'a', 'tracker': 'ours (background cue)', 'precision_20px': 0.97, 'precision_20px_mean': 0.9},
            {'sequence': 'a', 'tracker': 'MIL', 'precision_20px': 0.8, 'precision_20px_mean': 0.95},
            {'sequence': 'a', 'tracker': 'KCF', 'precision_20px': 0.5},
            {'sequence': 'a', 'tracker': 'CSRT', 'precision_20px': 1.0},  # shown, not a bar
            {'sequence': 'b', 'tracker': 'ours (background + skin)', 'precision_20px': 0.9},
            {'sequence': 'b', 'tracker': 'CamShift', 'precision_20px': 0.9},
        ],
    }
    verdicts = {row['check']: (row['bar'], row['met']) for row in _acceptance(results)}
    assert verdicts == {
        'particle filter step, 500 particles (ms)': (2.0, True),
        'pipeline (ms) <= KCF': (2.0, False),
        'pipeline (ms) <= CSRT / 5': (5.0, True),
        'a: mean precision at 20 px >= CamShift, MIL, KCF': (0.95, False),
        'b: mean precision at 20 px >= CamShift, MIL, KCF': (0.9, True),
    }
    assert _acceptance({}) == []
