"""``stage_timings`` (make bench's speed section) on a few frames: every stage and pipeline timed."""

from __future__ import annotations

import pytest
from conftest import REPO

from human_tracker.evaluation import speed
from human_tracker.evaluation.speed import PARTICLE_COUNTS, stage_timings
from human_tracker.io.sequences import open_sequence


def test_every_whole_pipeline_is_the_median_of_its_passes(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each whole pipeline runs afresh in each of PIPELINE_PASSES passes (here 3), and its
    median pass is reported: passes measured 3, 1 and 2 ms (CPU 30, 10, 20) give 2 (20)."""
    frames = list(open_sequence(REPO / 'bags' / 'head_basic'))[:4]
    pipelines = ('pipeline', 'pipeline_full_size', 'hand_pipeline', 'person_pipeline')
    by_pass = (3.0, 1.0, 2.0)
    counts: list[int] = []
    measure = speed._wall_and_cpu_ms

    def measured(run: object, count: int) -> tuple[float, float]:
        measure(run, count)  # type: ignore[arg-type]
        counts.append(count)
        figure = by_pass[(len(counts) - 1) // len(pipelines)]
        return figure, 10.0 * figure

    monkeypatch.setattr(speed, 'PIPELINE_PASSES', len(by_pass))
    monkeypatch.setattr(speed, '_wall_and_cpu_ms', measured)
    timings = stage_timings([f.image for f in frames], [f.ground_truth for f in frames], scale=0.5)
    stages = ('conversion', 'edges', 'colour_edges', 'background', 'flow', 'skin')
    filters = (f'particle_filter_{p}' for p in PARTICLE_COUNTS)
    assert set(timings) == {*stages, *filters, *pipelines, *(f'{p}_cpu' for p in pipelines)}
    assert all(timings[stage] > 0 for stage in stages)
    assert counts == [len(frames)] * (len(by_pass) * len(pipelines))
    assert all(timings[p] == 2.0 and timings[f'{p}_cpu'] == 20.0 for p in pipelines)
