"""``poses.csv``, the table ``human_tracker track`` writes: one row per frame and target, and its readers."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TypeVar

import numpy as np

from human_tracker.vision.geometry.boxes import Box

__all__ = ['POSE_COLUMNS', 'read_covariances', 'read_ids', 'read_poses', 'read_tracks']

POSE_COLUMNS = (
    'frame',
    'stamp_ns',
    'x',
    'y',
    'scale',
    'theta',
    'confidence',
    'status',
    'box_x',
    'box_y',
    'box_w',
    'box_h',
    'shape',
    'facing',
    'motion_support',
    'skin_support',
    'appearance_distance',
    'centre_var_x',
    'centre_cov_xy',
    'centre_var_y',
    'id',
    'kind',
    'person',
    'target',
    'gesture',
)
_T = TypeVar('_T')


def read_poses(path: str | Path, kind: str | None = None) -> list[Box | None]:
    """Boxes from a ``poses.csv`` written by :func:`~human_tracker.offline.track_sequence`, one per frame (None where
    not tracked): of its one target, or of the target of ``kind`` in a person's table.

    Raises:
        ValueError: Not such a table (:func:`read_tracks`), no target of ``kind`` in it, or a
            person's table and no ``kind``.
    """
    return _one_target(path, read_tracks(path), kind)


def read_covariances(path: str | Path, kind: str | None = None) -> list[np.ndarray | None]:
    """The ``(2, 2)`` covariance (pixels²) of each box's centre in a ``poses.csv``, one per
    frame (None where not tracked), of the target :func:`read_poses` reads."""
    return _one_target(path, _read_table(path)[2], kind)


def _one_target(path: str | Path, tracks: dict[str, list[_T]], kind: str | None) -> list[_T]:
    """The column of :func:`read_poses`'s target among a table's ``tracks``."""
    if kind is None and len(tracks) > 1:
        raise ValueError(f'{path} follows a person ({", ".join(tracks)}): name the kind to read')
    if kind is not None and kind not in tracks:
        raise ValueError(f'{path} has no {kind} (it has {", ".join(tracks)})')
    return tracks[kind] if kind is not None else next(iter(tracks.values()))


def read_tracks(path: str | Path) -> dict[str, list[Box | None]]:
    """Boxes from a ``poses.csv`` written by :func:`~human_tracker.offline.track_sequence`, by target (one list for
    one target; for a person, by its name: ``head``, ``hand``, ``hand_2``, ``person_2/head``,
    ...), None where not tracked.

    Raises:
        ValueError: The file is not such a table (its header lacks the box columns, or a box
            value is not a number); the message names the file.
    """
    return _read_table(path)[0]


def read_ids(path: str | Path) -> dict[str, list[int]]:
    """The targets' ids from a ``poses.csv`` (as :func:`read_tracks`; 0 where a target has none).
    A kind whose rows carry no id at all (the demo's table, from ``pose`` over DDS) is one
    track: id 1 wherever it has a box."""
    boxes, ids, _ = _read_table(path)
    for kind, column in ids.items():
        if not any(column):
            ids[kind] = [int(box is not None) for box in boxes[kind]]
    return ids


def _read_table(
    path: str | Path,
) -> tuple[dict[str, list[Box | None]], dict[str, list[int]], dict[str, list[np.ndarray | None]]]:
    """Boxes, ids and box-centre covariances of a ``poses.csv``, by target (its ``target``
    column, else its kind; see :func:`read_tracks`), one per frame of the table: None, 0 and
    None on a frame without its row (a covariance also where a table has none)."""
    columns = ('box_x', 'box_y', 'box_w', 'box_h')
    frames: dict[str, None] = {}
    rows: dict[str, dict[str, tuple[Box | None, int, np.ndarray | None]]] = {}
    try:
        with Path(path).open(newline='') as handle:
            reader = csv.DictReader(handle)
            missing = [c for c in columns if c not in (reader.fieldnames or [])]
            if missing:
                raise ValueError(f'{path} is not a poses.csv written by `track`: no column {", ".join(missing)}')
            for row in reader:
                values = [row[k] for k in columns]
                box = None if '' in values or None in values else tuple(float(v) for v in values)
                spread = [row.get(k) or '' for k in ('centre_var_x', 'centre_cov_xy', 'centre_var_y')]
                covariance = None
                if box is not None and '' not in spread:
                    var_x, cov_xy, var_y = (float(v) for v in spread)
                    covariance = np.array([[var_x, cov_xy], [cov_xy, var_y]])
                frame = row.get('frame') or str(len(frames))
                frames[frame] = None
                target = row.get('target') or row.get('kind') or ''
                rows.setdefault(target, {})[frame] = (box, int(row.get('id') or 0), covariance)
    except (UnicodeDecodeError, csv.Error) as err:
        raise ValueError(f'{path} is not a poses.csv written by `track`: {err}') from err
    if not rows:
        return {'': []}, {'': []}, {'': []}
    table = {target: [by_frame.get(f, (None, 0, None)) for f in frames] for target, by_frame in rows.items()}
    boxes = {target: [row[0] for row in column] for target, column in table.items()}
    ids = {target: [row[1] for row in column] for target, column in table.items()}
    covariances = {target: [row[2] for row in column] for target, column in table.items()}
    return boxes, ids, covariances
