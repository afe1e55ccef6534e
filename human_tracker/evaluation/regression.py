"""What the tracker does, recorded so that a refactor can show it changed nothing.

``record`` runs ``track`` on every bundled bag and every real sequence (the target its
ground truth outlines, from its first box and started by itself, and a person where a person
is in view) with seeds 0-4, and writes the SHA-256 of each run's ``poses.csv`` with the run's
precision and how many frames each target spent in each state; ``check`` runs them again and
lists the runs that differ. The file is a test fixture (``test/data/pose_hashes.json``):
``make test`` checks the bags at seed 0, ``make regression`` every run (about 30 minutes on
two cores).

The poses are the same to the last bit only on the processor and libraries they were recorded
with (numba compiles for the host, whose instructions round differently; OpenCV's versions
differ in their filters), so the record names them (:func:`platform`). There the check is
exact; elsewhere a run differs when its precision moves by more than
:data:`PRECISION_TOLERANCE` or a target's frames in a state by more than
:data:`STATE_TOLERANCE` of the frames (docs/evaluation.md: how far a figure moves between
processors).

    python -m human_tracker.evaluation.regression record --jobs 2
    python -m human_tracker.evaluation.regression check --fixture test/data/pose_hashes.json --jobs 2
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import sys
import tempfile
from collections.abc import Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from human_tracker.io.sequences import open_sequence
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.filter.contour_filter import TrackerParameters

__all__ = [
    'PRECISION_TOLERANCE',
    'SEEDS',
    'STATE_TOLERANCE',
    'Run',
    'check',
    'difference',
    'main',
    'platform',
    'pose_hash',
    'record',
    'runs',
    'state_counts',
]

SEEDS = (0, 1, 2, 3, 4)
REPO = Path(__file__).resolve().parents[2]
BAGS = REPO / 'bags'
REAL = REPO.parent / 'shared' / 'data' / 'real'
# Real sequences where a person's head and hands are in view: tracked as a person too.
PEOPLE = ('hand2', 'seated_agbani', 'interview_alberto')
PRECISION_TOLERANCE = 0.02
"""How far a run's precision at 20 px may move on another processor and still be the same behaviour."""
STATE_TOLERANCE = 0.02
"""How far a target's frames in a state may move, as a share of the run's frames (at least 2 frames)."""


@dataclass(frozen=True)
class Run:
    """One recorded run: an input, what is tracked, whether from the first box, the seed."""

    source: Path
    target: str
    from_box: bool
    seed: int

    @property
    def key(self) -> str:
        """``<input>/<target>/<box|alone>/seed<N>``: the run's name in the fixture."""
        return f'{self.source.name}/{self.target}/{"box" if self.from_box else "alone"}/seed{self.seed}'


def runs(seeds: Iterable[int] = SEEDS, *, real: bool = True) -> Iterator[Run]:
    """Every run of the record: the bags, then the real sequences present beside the repository."""
    sources = sorted(p for p in BAGS.iterdir() if (p / 'metadata.yaml').exists())
    if real and REAL.is_dir():
        sources += sorted(_readable(p) for p in REAL.iterdir() if p.is_dir())
    for source in sources:
        sequence = open_sequence(source)
        target = sequence.target or ('hand' if source.name == 'hand2' else 'head')
        targets = [target] + (['person'] if source.name in PEOPLE else [])
        for kind in targets:
            boxed = kind != 'person' and _first_box(source) is not None
            for from_box in (True, False) if boxed else (False,):
                for seed in seeds:
                    yield Run(source, kind, from_box, seed)


def _readable(folder: Path) -> Path:
    """A real sequence's folder, or the one video in it (``vtest/vtest.avi``)."""
    videos = [p for p in folder.iterdir() if p.suffix in ('.avi', '.mp4')]
    return videos[0] if len(videos) == 1 and not (folder / 'img').is_dir() else folder


def _first_box(source: Path) -> tuple[float, ...] | None:
    """The ground truth of frame 0 (the box a run from the first box starts from), or None."""
    frame = next(iter(open_sequence(source)))
    return frame.ground_truth


def platform() -> str:
    """The processor numba compiles for (LLVM's name of the host CPU), numpy's and OpenCV's versions."""
    import cv2
    import llvmlite.binding as llvm
    import numpy as np

    return f'{llvm.get_host_cpu_name()}, numpy {np.__version__}, OpenCV {cv2.__version__}'


def pose_hash(poses: Path) -> str:
    """SHA-256 of a ``poses.csv``: every pose, state and status, nothing of the machine's speed."""
    return hashlib.sha256(poses.read_bytes()).hexdigest()


def state_counts(poses: Path) -> dict[str, dict[str, int]]:
    """How many rows of a ``poses.csv`` each target (its ``target`` column) has in each status."""
    counts: dict[str, dict[str, int]] = {}
    with poses.open(newline='') as handle:
        for row in csv.DictReader(handle):
            target = counts.setdefault(row['target'] or row['kind'], {})
            target[row['status']] = target.get(row['status'], 0) + 1
    return counts


def difference(expected: dict[str, Any], found: dict[str, Any], exact: bool) -> str | None:
    """What differs between a recorded run and the same run now (None: the same behaviour):
    its poses to the bit when ``exact``, else its precision and state counts within
    :data:`PRECISION_TOLERANCE` and :data:`STATE_TOLERANCE`."""
    before, after = expected['precision_20px'], found['precision_20px']
    precision = f'precision {before} -> {after}'
    if exact:
        return None if expected['sha256'] == found['sha256'] else f'poses differ ({precision})'
    if (before is None) != (after is None) or (before is not None and abs(before - after) > PRECISION_TOLERANCE):
        return precision
    was, now = expected.get('states', {}), found['states']
    frames = max((sum(counts.values()) for counts in now.values()), default=0)
    allowed = max(2, round(STATE_TOLERANCE * frames))
    for target in sorted(set(was) | set(now)):
        a, b = was.get(target, {}), now.get(target, {})
        for status in sorted(set(a) | set(b)):
            if abs(a.get(status, 0) - b.get(status, 0)) > allowed:
                return f'{target} {status} frames {a.get(status, 0)} -> {b.get(status, 0)} ({precision})'
    return None


def _track(run: Run, out: Path) -> dict[str, Any]:
    options = TrackOptions(
        target=run.target,
        init=_first_box(run.source) if run.from_box else None,
        filter_parameters=TrackerParameters(seed=run.seed),
        video=False,
        progress=False,
    )
    summary = track_sequence(run.source, out, options)
    precision = summary.get('precision_20px')
    return {
        'sha256': pose_hash(out / 'poses.csv'),
        'precision_20px': None if precision is None else round(precision, 4),
        'states': state_counts(out / 'poses.csv'),
    }


def _track_apart(run: Run) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as scratch:
        return _track(run, Path(scratch) / 'out')


def record(selected: Iterable[Run], jobs: int = 1) -> dict[str, dict[str, Any]]:
    """Each run's pose hash and precision, by :attr:`Run.key`, ``jobs`` runs at a time (each
    in a process of its own: a run's poses do not depend on the others)."""
    selected = list(selected)
    found = {}
    with ProcessPoolExecutor(jobs) if jobs > 1 else nullcontext() as pool:
        results = pool.map(_track_apart, selected) if pool is not None else map(_track_apart, selected)
        for run, result in zip(selected, results, strict=True):
            found[run.key] = result
            print(f'{run.key}: {result}', file=sys.stderr, flush=True)
    return found


def check(
    fixture: dict[str, dict[str, Any]], selected: Iterable[Run], jobs: int = 1, *, exact: bool = True
) -> list[str]:
    """The runs of ``selected`` that differ from ``fixture`` (:func:`difference`; a missing key is a difference)."""
    differ = []
    for key, found in record(selected, jobs).items():
        expected = fixture.get(key)
        why = 'not recorded' if expected is None else difference(expected, found, exact)
        if why is not None:
            differ.append(f'{key}: {why}')
    return differ


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='regression', description=__doc__.split('\n\n')[0])
    parser.add_argument('command', choices=('record', 'check'))
    parser.add_argument('--fixture', type=Path, default=REPO / 'test' / 'data' / 'pose_hashes.json')
    parser.add_argument('--only', default='', help='only runs whose key contains this text')
    parser.add_argument('--jobs', type=int, default=1, help='runs at a time')
    options = parser.parse_args(argv)
    selected = [run for run in runs() if options.only in run.key]
    known = json.loads(options.fixture.read_text()) if options.fixture.exists() else {}
    if options.command == 'record':
        # Recorded runs join (or replace) those already in the fixture, on the same platform.
        if known.get('platform', platform()) != platform():
            known = {}
        found = {'platform': platform(), 'runs': known.get('runs', {}) | record(selected, options.jobs)}
        options.fixture.write_text(json.dumps(found, indent=1, sort_keys=True) + '\n')
        return 0
    exact = known.get('platform') == platform()
    if not exact:
        print(f'the record was made on {known.get("platform")}, this is {platform()}: compared within tolerance')
    differ = check(known['runs'], selected, options.jobs, exact=exact)
    print('\n'.join(differ) or f'{len(selected)} runs: the same {"poses" if exact else "behaviour"}')
    return 1 if differ else 0


if __name__ == '__main__':
    sys.exit(main())
