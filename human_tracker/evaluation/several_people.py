"""Several people in one scene, seed by seed: every ground-truth track and the identities.

The real sequences hold one person each; the two-person bag (``people_crossing``: one person
waves beside the other, who walks across in front) is the situation they lack. Each seed
is one run of ``track --target person --max-people 2``; a row per seed shows every track's
precision at 20 px (against the followed target of its kind that matches it best) and every
target against every track (MOTA, IDF1, identity switches: :mod:`~human_tracker.evaluation.identity`).
Rows, not a mean: a robot runs one seed, and a bad seed is a person lost.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.tracker import TrackerParameters

__all__ = ['two_people_rows']


def two_people_rows(bag: Path, out: Path, seeds: Iterable[int] = range(10)) -> list[dict[str, object]]:
    """One row per seed of two people followed in ``bag`` (each run written under ``out``):
    the seed, each ground-truth track's precision at 20 px, MOTA, IDF1 and identity switches.
    Empty when ``bag`` is absent."""
    if not bag.is_dir():
        return []
    rows: list[dict[str, object]] = []
    for seed in seeds:
        options = TrackOptions(
            target='person',
            max_people=2,
            filter_parameters=TrackerParameters(seed=seed),
            video=False,
            progress=False,
        )
        summary = track_sequence(bag, out / f'seed_{seed}', options)
        tracks = {name: round(float(score['precision_20px']), 3) for name, score in summary['tracks'].items()}
        identity = summary['all_tracks']
        rows.append(
            {
                'seed': seed,
                **tracks,
                'mota': round(float(identity['mota']), 3),
                'idf1': round(float(identity['idf1']), 3),
                'id_switches': int(identity['id_switches']),
            }
        )
    return rows
