"""Real sequences under camera conditions they were not recorded in, ours with a setting and without.

- **Small targets in wide frames** (:func:`widen`). A robot's 640x480 camera sees a person a
  few metres away as small as our real sequences' 320x240 frames show them near. Set in a
  frame twice as wide and high (a grey border round it), a sequence keeps its target's camera
  pixels while the default reduction to the working width makes it twice as small: the case
  ``min_target_width`` is for (:meth:`~human_tracker.vision.track.target.TargetTracker.working_width`).
  Ours runs with the rule and without it (``min_target_width`` 0).
- **Dim light** (:func:`dim`). A camera at the end of its exposure range (a dim room) gives
  frames far darker than our sequences': ``hand2`` at 0.4 of its brightness. Ours runs with
  the skin stage's exposure normalisation and without it (``max_exposure_gain`` 1).
- **A shaking camera** (:func:`shake`). A robot's camera jitters as it drives or turns its
  head: each frame a crop of the sequence's whose offset follows a random walk, as far as
  :data:`SHAKE_MARGIN` pixels from the middle. Ours runs carrying its particles with the
  camera's motion and without (``compensate_camera``).
- **A slow camera** (:func:`slow_camera`). A robot's camera at 10 Hz, or a busy tracker that
  drops two frames of three: every :data:`SLOW_STEP`-th frame, stamped at that rate. Ours runs
  with frames that far apart waiting for their own face detector run and without
  (``detector_wait_interval`` 1 s: the faces a frame late).

Each from the first box and without one, over a few seeds.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import replace
from itertools import islice
from pathlib import Path

import cv2
import numpy as np

from human_tracker.io.bags import write_bag
from human_tracker.io.sequences import open_sequence, read_groundtruth, write_groundtruth
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.vision.cues.skin import SkinParameters
from human_tracker.vision.filter.contour_filter import TrackerParameters
from human_tracker.vision.track.parameters import TargetParameters, parameters_for

__all__ = [
    'DIM_BRIGHTNESS',
    'SEQUENCES',
    'SHAKEN',
    'SHAKE_MARGIN',
    'SLOW',
    'SLOW_STEP',
    'dim',
    'dim_light_rows',
    'shake',
    'shaken_camera_rows',
    'slow_camera',
    'slow_camera_rows',
    'small_target_rows',
    'widen',
]

# The sequences set in wide frames and their targets: the real hand, the smallest head, and a
# head already as small as the working frame allows once reduced (trellis, 34 working pixels),
# as a control.
SEQUENCES = {'hand2': 'hand', 'sunshade': 'head', 'trellis': 'head'}
BORDER_GREY = 120
# The brightness of the dimmed frames, a fraction of the sequence's own.
DIM_BRIGHTNESS = 0.4
# The sequences shaken and their targets: the real hand and the two heads the shake moved most.
SHAKEN = {'hand2': 'hand', 'david_colour': 'head', 'interview_alberto': 'head'}
# How far a shaken frame's crop moves from the middle (pixels), the standard deviation of its
# step from one frame to the next, and how much of its offset it keeps (an AR(1) walk).
SHAKE_MARGIN = 20
SHAKE_STEP = 6.0
SHAKE_MEMORY = 0.7
# The sequences a slow camera sees and their targets: the heads that move most from frame to
# frame (a person walking across, a camera that pans) and the real hand.
SLOW = {'sunshade': 'head', 'david_colour': 'head', 'trellis': 'head', 'hand2': 'hand'}
# Every this many frames of a 30 Hz sequence: a 10 Hz camera.
SLOW_STEP = 3
# A folder of frames' nominal rate (its frames' stamps).
SEQUENCE_RATE = 30.0


def widen(sequence: Path, out: Path) -> Path:
    """``sequence`` (a folder with ``img/`` and ``groundtruth.txt``) in the middle of frames twice
    as wide and high, written to ``out`` (PNG frames, boxes moved with them); returns ``out``."""
    dx = dy = 0

    def wider(image: np.ndarray) -> np.ndarray:
        nonlocal dx, dy
        dx, dy = image.shape[1] // 2, image.shape[0] // 2
        return cv2.copyMakeBorder(image, dy, dy, dx, dx, cv2.BORDER_CONSTANT, value=(BORDER_GREY,) * 3)

    _rewrite_frames(sequence, out, wider)
    boxes = read_groundtruth(sequence / 'groundtruth.txt')
    write_groundtruth(
        out / 'groundtruth.txt', [None if b is None else (b[0] + dx, b[1] + dy, b[2], b[3]) for b in boxes]
    )
    return out


def dim(sequence: Path, out: Path, brightness: float = DIM_BRIGHTNESS) -> Path:
    """``sequence``'s frames at ``brightness`` times their own (rounded, as a camera's darker
    exposure quantises them), written to ``out`` with its boxes; returns ``out``."""
    _rewrite_frames(sequence, out, lambda image: cv2.convertScaleAbs(image, alpha=brightness))
    write_groundtruth(out / 'groundtruth.txt', read_groundtruth(sequence / 'groundtruth.txt'))
    return out


def shake(sequence: Path, out: Path, seed: int = 7) -> Path:
    """``sequence``'s frames seen by a shaking camera, written to ``out`` with its boxes moved;
    returns ``out``. Each frame is cropped :data:`SHAKE_MARGIN` pixels in from every side,
    offset by a seeded walk: ``d_k = SHAKE_MEMORY d_(k-1) + N(0, SHAKE_STEP²)`` per axis,
    clipped to the margin (steps of up to 15 pixels, as a robot's head that jolts)."""
    rng = np.random.default_rng(seed)
    offset = np.zeros(2)
    offsets = []

    def shaken(image: np.ndarray) -> np.ndarray:
        nonlocal offset
        offset = np.clip(SHAKE_MEMORY * offset + rng.normal(0.0, SHAKE_STEP, 2), -SHAKE_MARGIN, SHAKE_MARGIN)
        dx, dy = (int(round(v)) for v in offset)
        offsets.append((dx, dy))
        height, width = image.shape[:2]
        m = SHAKE_MARGIN
        return image[m + dy : height - m + dy, m + dx : width - m + dx]

    _rewrite_frames(sequence, out, shaken)
    boxes = read_groundtruth(sequence / 'groundtruth.txt')
    moved = [
        None if box is None else (box[0] - SHAKE_MARGIN - dx, box[1] - SHAKE_MARGIN - dy, box[2], box[3])
        for box, (dx, dy) in zip(boxes, offsets, strict=False)
    ]
    write_groundtruth(out / 'groundtruth.txt', moved)
    return out


def slow_camera(sequence: Path, out: Path, step: int = SLOW_STEP) -> Path:
    """Every ``step``-th frame of ``sequence`` (a folder with ``img/`` and ``groundtruth.txt``,
    stamped at its nominal rate, :data:`SEQUENCE_RATE`) with its box and its own stamp,
    recorded as a bag of raw frames (``1 / step`` of the rate); returns ``out`` (replaced if
    it exists)."""
    if out.exists():
        shutil.rmtree(out)
    frames = ((f.stamp_ns, f.image, f.ground_truth) for f in islice(open_sequence(sequence), 0, None, step))
    return write_bag(out, frames, compressed=False, target='hand' if 'hand' in sequence.name else 'head')


def small_target_rows(real_data: Path, out: Path, seeds: tuple[int, ...] = (0, 1, 2)) -> list[dict[str, object]]:
    """Precision at 20 px (mean, min, max over ``seeds``) and the worst confident-wrong share of
    ours on each of :data:`SEQUENCES` widened, with ``min_target_width`` and without, from the
    first box and without one; sequences absent from ``real_data`` are skipped."""
    return _with_and_without(real_data, out, SEQUENCES, widen, 'widened', 'min_target_width', 0.0, seeds)


def dim_light_rows(real_data: Path, out: Path, seeds: tuple[int, ...] = (0, 1, 2)) -> list[dict[str, object]]:
    """As :func:`small_target_rows`, for ``hand2``'s hand dimmed (:func:`dim`), with the skin
    stage's exposure normalisation and without; none when ``hand2`` is absent."""
    if not (real_data / 'hand2' / 'img').is_dir():
        return []
    folder = dim(real_data / 'hand2', out / 'hand2_dim')
    parameters, skin = parameters_for('hand'), SkinParameters()
    values = {skin.max_exposure_gain: (parameters, skin), 1.0: (parameters, replace(skin, max_exposure_gain=1.0))}
    name = f'hand2 at {DIM_BRIGHTNESS:g} brightness'
    return _rows(folder, name, 'hand', 'max_exposure_gain', values, seeds, out / 'hand2_dim_runs')


def shaken_camera_rows(real_data: Path, out: Path, seeds: tuple[int, ...] = (0, 1, 2)) -> list[dict[str, object]]:
    """As :func:`small_target_rows`, for :data:`SHAKEN` shaken (:func:`shake`), with the particles
    carried by the camera's motion and without."""
    return _with_and_without(real_data, out, SHAKEN, shake, 'shaken', 'compensate_camera', False, seeds)


def slow_camera_rows(real_data: Path, out: Path, seeds: tuple[int, ...] = (0, 1, 2)) -> list[dict[str, object]]:
    """As :func:`small_target_rows`, for :data:`SLOW` at a third of their frame rate
    (:func:`slow_camera`), frames that far apart waiting for their own face detector run and
    not (``detector_wait_interval`` 1 s)."""
    rate = f'{SEQUENCE_RATE / SLOW_STEP:g} Hz'
    return _with_and_without(real_data, out, SLOW, slow_camera, f'at {rate}', 'detector_wait_interval', 1.0, seeds)


def _with_and_without(
    real_data: Path,
    out: Path,
    sequences: dict[str, str],
    rewrite: Callable[[Path, Path], Path],
    label: str,
    setting: str,
    off: float | bool,
    seeds: tuple[int, ...],
) -> list[dict[str, object]]:
    """The rows of each of ``sequences`` (name: target) present in ``real_data``, its frames
    rewritten by ``rewrite`` (a sequence and an output folder to the new sequence), with the
    target's default ``setting`` and with ``off``."""
    rows = []
    for name, target in sequences.items():
        if not (real_data / name / 'img').is_dir():
            continue
        folder = rewrite(real_data / name, out / f'{name}_{label}'.replace(' ', '_'))
        parameters = parameters_for(target)
        values = {
            float(getattr(parameters, setting)): (parameters, SkinParameters()),
            float(off): (replace(parameters, **{setting: off}), SkinParameters()),
        }
        runs = folder.with_name(f'{folder.name}_runs')
        rows += _rows(folder, f'{name} {label}', target, setting, values, seeds, runs)
    return rows


def _rows(
    folder: Path,
    name: str,
    target: str,
    setting: str,
    values: dict[float, tuple[TargetParameters, SkinParameters]],
    seeds: tuple[int, ...],
    out: Path,
) -> list[dict[str, object]]:
    """One row per value of ``setting`` (``values``: the parameters each gives) and start (the
    first box, none): precision at 20 px over ``seeds`` and the worst confident-wrong share."""
    first = next(iter(open_sequence(folder))).ground_truth
    rows = []
    for value, (parameters, skin) in values.items():
        for init in (first, None):
            precision, wrong = [], []
            for seed in seeds:
                options = TrackOptions(
                    target=target,
                    init=init,
                    target_parameters=parameters,
                    skin_parameters=skin,
                    filter_parameters=TrackerParameters(seed=seed),
                    video=False,
                    progress=False,
                )
                summary = track_sequence(folder, out / f'{value}_{init is not None}_{seed}', options)
                precision.append(float(summary['precision_20px']))
                wrong.append(float(summary['confident_wrong']))
            rows.append(
                {
                    'sequence': name,
                    setting: value,
                    'start': 'first box' if init is not None else 'none',
                    'runs': len(seeds),
                    'precision_20px_mean': round(float(np.mean(precision)), 3),
                    'precision_20px_min': round(min(precision), 3),
                    'precision_20px_max': round(max(precision), 3),
                    'confident_wrong_max': round(max(wrong), 3),
                }
            )
    return rows


def _rewrite_frames(sequence: Path, out: Path, change: Callable[[np.ndarray], np.ndarray]) -> None:
    """Each frame of ``sequence/img`` passed through ``change`` (an image to an image), written
    to ``out/img`` as PNG."""
    (out / 'img').mkdir(parents=True, exist_ok=True)
    paths = sorted(p for p in (sequence / 'img').iterdir() if p.is_file())
    for index, path in enumerate(paths):
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        cv2.imwrite(str(out / 'img' / f'{index:05d}.png'), change(image))
