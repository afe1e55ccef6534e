"""The tracker's behaviour on the bundled bags is the recorded one (``test/data/pose_hashes.json``,
written by ``python -m human_tracker.evaluation.regression record``): the same poses to the bit
on the processor it was recorded on, elsewhere the same precision and state counts within the
stated tolerance. A change of behaviour fails here on any machine; ``make regression`` checks
every recorded run, real sequences and seeds 0-4."""

from __future__ import annotations

import json

import pytest
from conftest import REPO

from human_tracker.evaluation.regression import check, difference, platform, runs

FIXTURE = json.loads((REPO / 'test' / 'data' / 'pose_hashes.json').read_text())
EXACT = FIXTURE['platform'] == platform()


@pytest.mark.parametrize('run', list(runs(seeds=(0,), real=False)), ids=lambda r: r.key)
def test_the_behaviour_on_the_bags_is_the_recorded_one(run) -> None:
    assert check(FIXTURE['runs'], [run], exact=EXACT) == []


def test_the_tolerant_comparison_sees_a_change_of_state_or_precision() -> None:
    recorded = FIXTURE['runs']['head_basic/head/alone/seed0']
    assert difference(recorded, recorded, exact=False) is None
    lost = json.loads(json.dumps(recorded))
    lost['states']['head']['TRACKING'] -= 5
    lost['states']['head']['LOST'] = lost['states']['head'].get('LOST', 0) + 5
    assert 'head LOST frames 0 -> 5' in difference(recorded, lost, exact=False)
    worse = {**recorded, 'precision_20px': recorded['precision_20px'] - 0.05}
    assert 'precision' in difference(recorded, worse, exact=False)
    assert difference(recorded, {**recorded, 'sha256': '0' * 64}, exact=True) is not None
