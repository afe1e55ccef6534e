"""OpenCV trackers as baselines, run on the same frames from the same first-frame box.

CamShift and MIL come with OpenCV's main wheel; KCF and CSRT with the contrib wheel, which
cannot share a virtualenv with the main one, so this module imports nothing but numpy and
OpenCV and can run in either: ``python -m human_tracker.evaluation.baselines --tracker KCF
--frames DIR --init x,y,w,h --out result.json`` reads the sorted images of DIR.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np

__all__ = ['BASELINES', 'CamShiftTracker', 'make_baseline', 'run_baseline']

Box = tuple[float, float, float, float]
BASELINES = ('CamShift', 'MIL', 'KCF', 'CSRT')


class CamShiftTracker:
    """CamShift on the back-projection of the target's hue histogram (intensity for grey images)."""

    def __init__(self) -> None:
        self.histogram: np.ndarray | None = None
        self.window: tuple[int, int, int, int] = (0, 0, 1, 1)
        self.channel = 0

    def _plane(self, image: np.ndarray) -> np.ndarray:
        hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
        return hsv[..., self.channel]

    def init(self, image: np.ndarray, box: Box) -> None:
        x, y, w, h = (int(round(v)) for v in box)
        hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
        roi = hsv[y : y + h, x : x + w]
        # Hue is meaningless on a grey (or unsaturated) target: use intensity there.
        self.channel = 0 if roi.size and np.median(roi[..., 1]) > 40 else 2
        bins, top = (180, 180) if self.channel == 0 else (64, 256)
        plane = roi[..., self.channel]
        self.histogram = cv2.calcHist([plane], [0], None, [bins], [0, top])
        cv2.normalize(self.histogram, self.histogram, 0, 255, cv2.NORM_MINMAX)
        self.window = (x, y, max(w, 1), max(h, 1))
        self.top = top

    def update(self, image: np.ndarray) -> tuple[bool, Box]:
        assert self.histogram is not None
        projection = cv2.calcBackProject([self._plane(image)], [0], self.histogram, [0, self.top], 1)
        criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 1)
        _, self.window = cv2.CamShift(projection, self.window, criteria)
        x, y, w, h = self.window
        if w <= 0 or h <= 0:
            return False, (0.0, 0.0, 0.0, 0.0)
        return True, (float(x), float(y), float(w), float(h))


def make_baseline(name: str) -> object:
    """A fresh tracker with OpenCV's ``init(image, box)`` / ``update(image)`` interface."""
    if name == 'CamShift':
        return CamShiftTracker()
    factory = getattr(cv2, f'Tracker{name}_create', None) or getattr(
        getattr(cv2, 'legacy', None), f'Tracker{name}_create', None
    )
    if factory is None:
        raise ValueError(f'OpenCV {cv2.__version__} here has no {name} tracker (KCF and CSRT need opencv-contrib)')
    return factory()


def run_baseline(name: str, frames: Iterable[np.ndarray], init: Box) -> tuple[list[Box | None], float, float]:
    """Track ``frames`` with baseline ``name`` from ``init``.

    The first frame is the initialisation frame and reports ``init`` (as in OTB); the timing
    covers the updates of the following frames only.

    Returns:
        The boxes, the mean wall-clock ms per frame and the mean CPU ms per frame (every
        thread of the process: OpenCV's parallel loops included).
    """
    tracker = make_baseline(name)
    boxes: list[Box | None] = []
    elapsed = busy = 0.0
    for index, image in enumerate(frames):
        if index == 0:
            tracker.init(image, tuple(int(round(v)) for v in init))  # type: ignore[attr-defined]
            boxes.append(tuple(float(v) for v in init))  # type: ignore[arg-type]
            continue
        start, cpu = time.perf_counter(), time.process_time()
        ok, box = tracker.update(image)  # type: ignore[attr-defined]
        elapsed += time.perf_counter() - start
        busy += time.process_time() - cpu
        boxes.append(tuple(float(v) for v in box) if ok else None)  # type: ignore[arg-type]
    updates = max(len(boxes) - 1, 1)
    return boxes, 1000.0 * elapsed / updates, 1000.0 * busy / updates


def main(argv: list[str] | None = None) -> int:
    """Run one baseline on a folder of frames; write its boxes and timing as JSON."""
    parser = argparse.ArgumentParser(description='Run an OpenCV baseline tracker on a folder of frames.')
    parser.add_argument('--tracker', required=True, choices=BASELINES)
    parser.add_argument('--frames', type=Path, required=True)
    parser.add_argument('--init', required=True, help='x,y,w,h')
    parser.add_argument('--out', type=Path, required=True)
    parser.add_argument('--threads', type=int, help="OpenCV's thread count (default: OpenCV's own, one per core)")
    options = parser.parse_args(argv)
    if options.threads is not None:
        cv2.setNumThreads(options.threads)
    init = tuple(float(v) for v in options.init.split(','))
    files = sorted(f for f in options.frames.iterdir() if f.suffix == '.png')  # not its groundtruth.txt
    images = (cv2.imread(str(f), cv2.IMREAD_COLOR) for f in files)
    boxes, ms, cpu_ms = run_baseline(options.tracker, images, init)  # type: ignore[arg-type]
    result = {
        'tracker': options.tracker,
        'opencv': cv2.__version__,
        'threads': cv2.getNumThreads(),
        'ms_per_frame': ms,
        'cpu_ms_per_frame': cpu_ms,
        'boxes': boxes,
    }
    options.out.write_text(json.dumps(result))
    return 0


if __name__ == '__main__':
    sys.exit(main())
