"""Hand tracking with skin colour (§3.2) on the bundled hand bags, against the same tracker without colour."""

from __future__ import annotations

import dataclasses

import pytest
from conftest import REPO

from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.target import parameters_for

HAND = parameters_for('hand')
VARIANTS = {
    # Skin labels in the likelihood (γ_colour) and colour edges: the hand's defaults.
    'colour term': (True, HAND),
    # The paper's other use: skin regions delimit where the template is fitted.
    'skin regions': (True, dataclasses.replace(HAND, colour_mode='mask')),
    # No colour at all: intensity edges and the background cue, as in §2.
    'no colour': (False, dataclasses.replace(HAND, colour_edges=False, init_region='motion')),
}


def _precision(bag: str, skin: bool, parameters, out) -> float:
    options = TrackOptions(target='hand', skin=skin, target_parameters=parameters, video=False, progress=False)
    return float(track_sequence(REPO / 'bags' / bag, out, options)['precision_20px'])


@pytest.mark.parametrize('bag', ['hand_wave', 'hand_cluttered'])
def test_hand_with_colour_beats_the_tracker_without(bag, tmp_path) -> None:
    scores = {name: _precision(bag, skin, p, tmp_path / name) for name, (skin, p) in VARIANTS.items()}
    print(f'{bag}: precision at 20 px (started from skin and motion, no box): {scores}')
    assert scores['colour term'] >= 0.9
    assert scores['colour term'] >= scores['no colour']
    if bag == 'hand_cluttered':
        # A hand as bright as the wood behind it: without colour its edges are not seen.
        assert scores['no colour'] < 0.5
