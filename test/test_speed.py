"""``stage_timings`` (make bench's speed section) on a few frames: every stage and pipeline timed."""

from __future__ import annotations

import pytest
from conftest import REPO

from human_tracker.evaluation import speed
from human_tracker.evaluation.speed import PARTICLE_COUNTS, stage_timings
from human_tracker.io.sequences import open_sequence


def test_every_stage_and_pipeline_is_timed_in_every_pass(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each whole pipeline runs PIPELINE_PASSES times, afresh, and its median pass is reported."""
    frames = list(open_sequence(REPO / 'bags' / 'head_basic'))[:4]
    passes: list[int] = []
    measure = speed._wall_and_cpu_ms
    monkeypatch.setattr(speed, '_wall_and_cpu_ms', lambda run, count: passes.append(count) or measure(run, count))
    timings = stage_timings([f.image for f in frames], [f.ground_truth for f in frames], scale=0.5)
    pipelines = ('pipeline', 'pipeline_full_size', 'hand_pipeline', 'person_pipeline')
    stages = ('conversion', 'edges', 'colour_edges', 'background', 'flow', 'skin')
    filters = (f'particle_filter_{p}' for p in PARTICLE_COUNTS)
    expected = {*stages, *filters, *pipelines, *(f'{p}_cpu' for p in pipelines)}
    assert set(timings) == expected
    assert all(value > 0 for value in timings.values())
    assert passes == [len(frames)] * (speed.PIPELINE_PASSES * len(pipelines))
