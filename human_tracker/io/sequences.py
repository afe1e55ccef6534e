"""Sequences for offline tracking: a bag, a video file or a folder of frames, with ground truth.

A folder holds sorted image files (or an ``img/`` subfolder of them) and optionally
``groundtruth.txt``: one ``x,y,w,h`` line per frame (commas, tabs or spaces), ``0,0,0,0``
for a frame that is not annotated.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from human_tracker.io.bags import BagError, camera_frame_count, ground_truth_target, read_frames
from human_tracker.io.frames import FrameSourceError, open_frames
from human_tracker.io.images import ImageConversionError, message_to_bgr8

_LOG = logging.getLogger(__name__)

__all__ = [
    'SequenceError',
    'SequenceFrame',
    'Sequence',
    'open_sequence',
    'sequence_name',
    'read_groundtruth',
    'write_groundtruth',
]

Box = tuple[float, float, float, float]


class SequenceError(RuntimeError):
    """A sequence cannot be opened or read; the message says why."""


@dataclass
class SequenceFrame:
    """One frame: index, stamp (nanoseconds), ``(H, W, 3) uint8`` BGR image, ground truth or None.

    ``image`` is None when the frame could not be read or decoded; ``rejected`` says why. A bag
    with several ground-truth tracks (``person_1/head``, ...) gives each in ``ground_truths``.
    """

    index: int
    stamp_ns: int
    image: np.ndarray | None
    ground_truth: Box | None
    rejected: str = ''
    ground_truths: dict[str, Box | None] = field(default_factory=dict)


@dataclass
class Sequence:
    """An opened sequence: its name, nominal rate, what its ground truth outlines, and its frames.

    ``target`` is ``head`` or ``hand`` for a bag with ground truth, ``person`` for one with
    several tracks (:func:`~human_tracker.io.bags.ground_truth_target`), None otherwise.
    ``length`` is the number of frames expected (None: unknown). ``warnings`` collects, as the
    frames are read, what the reader found wrong (a video shorter than its header says); each
    is also logged.
    """

    name: str
    fps: float
    path: Path
    target: str | None = None
    length: int | None = None
    warnings: list[str] = field(default_factory=list)

    def __iter__(self) -> Iterator[SequenceFrame]:
        try:
            if _is_bag(self.path):
                for frame in read_frames(self.path, warn=self._warn):
                    try:
                        image, reason = message_to_bgr8(frame.message), ''
                    except ImageConversionError as err:
                        image, reason = None, str(err)
                    yield SequenceFrame(
                        frame.index, frame.stamp_ns, image, frame.ground_truth, reason, frame.ground_truths
                    )
                return
            source = open_frames(self.path)
            truth = read_groundtruth(self.path / 'groundtruth.txt') if self.path.is_dir() else []
            try:
                for index, image in enumerate(source):
                    box = truth[index] if index < len(truth) else None
                    reason = '' if image is not None else f'cannot read image {source.files[index]}'
                    yield SequenceFrame(index, int(round(index * 1e9 / self.fps)), image, box, reason)
                if source.truncated:
                    self._warn(
                        f'{self.path}: {source.read} frames read of the {source.announced} its header announces '
                        '(the file is truncated or damaged)'
                    )
            finally:
                source.close()
        except (BagError, FrameSourceError) as err:
            raise SequenceError(str(err)) from err

    def _warn(self, message: str) -> None:
        self.warnings.append(message)
        _LOG.warning(message)


def _is_bag(path: Path) -> bool:
    """A bag file, a bag's folder, or a folder holding one ``.mcap`` (a recording stopped before
    ros2 bag record wrote its metadata.yaml)."""
    if path.is_file():
        return path.suffix in ('.mcap', '.db3')
    return (path / 'metadata.yaml').exists() or len(list(path.glob('*.mcap'))) == 1


def open_sequence(path: str | Path) -> Sequence:
    """Open a bag (folder, ``.mcap`` or ``.db3``), a video file or a folder of frames.

    Raises:
        SequenceError: Nothing usable at ``path``.
    """
    path = Path(path)
    if not path.exists():
        raise SequenceError(f'{path} does not exist')
    if _is_bag(path):
        try:
            target, length = ground_truth_target(path), camera_frame_count(path)
        except BagError as err:
            raise SequenceError(str(err)) from err
        return Sequence(sequence_name(path), 30.0, path, target, length)
    try:
        source = open_frames(path)
    except FrameSourceError as err:
        raise SequenceError(str(err)) from err
    fps, length = source.fps, source.length
    source.close()
    return Sequence(sequence_name(path), fps, path, length=length)


def sequence_name(path: Path) -> str:
    """A sequence's name: its file's stem, or its folder's name (the parent's for the ``img/``
    folder of a benchmark sequence, whose name is the parent's)."""
    if path.is_file():
        return path.stem
    path = path.resolve()
    return path.parent.name if path.name == 'img' and path.parent.name else path.name


def read_groundtruth(path: Path) -> list[Box | None]:
    """Boxes of a ``groundtruth.txt`` (None for ``0,0,0,0`` lines); empty when the file is absent."""
    if not path.exists():
        return []
    boxes: list[Box | None] = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        fields = line.replace(',', ' ').replace('\t', ' ').split()
        if not fields:
            continue
        try:
            x, y, w, h = (float(v) for v in fields[:4])
        except ValueError as err:
            raise SequenceError(f'{path}:{number}: expected x,y,w,h, got {line!r}') from err
        boxes.append((x, y, w, h) if w > 0 and h > 0 else None)
    return boxes


def write_groundtruth(path: Path, boxes: list[Box | None]) -> None:
    """Write boxes as ``groundtruth.txt`` lines (``0,0,0,0`` for None)."""
    lines = ['0,0,0,0' if b is None else ','.join(f'{v:g}' for v in b) for b in boxes]
    path.write_text('\n'.join(lines) + '\n')
