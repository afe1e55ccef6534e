"""The tracker's poses on the bundled bags are the recorded ones (``test/data/pose_hashes.json``,
written by ``python -m human_tracker.evaluation.regression record``): a refactor that changes a
pose fails here. ``make regression`` checks every recorded run, real sequences and seeds 0-4."""

from __future__ import annotations

import json

import pytest
from conftest import REPO

from human_tracker.evaluation.regression import check, platform, runs

FIXTURE = json.loads((REPO / 'test' / 'data' / 'pose_hashes.json').read_text())


@pytest.mark.skipif(
    FIXTURE['platform'] != platform(),
    reason=f'poses recorded on {FIXTURE["platform"]}: the same to the bit only there',
)
@pytest.mark.parametrize('run', list(runs(seeds=(0,), real=False)), ids=lambda r: r.key)
def test_the_poses_on_the_bags_are_the_recorded_ones(run) -> None:
    assert check(FIXTURE['runs'], [run]) == []
