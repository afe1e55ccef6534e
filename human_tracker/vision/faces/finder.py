"""One face detector for every target on a frame: their searches in as few runs as cost least.

Each target's :class:`~human_tracker.vision.faces.schedule.FaceSchedule` says where it looks
on its working image of a frame (a :class:`Search`: a rectangle and the zoom at which the faces
it expects are just detectable). A :class:`FaceFinder` collects the frame's searches and runs
them together (:func:`plan_runs`): a search inside another is answered by it, and searches at
about one zoom (within a step of the detector's image pyramid) merge into one run over the
rectangle that bounds them when that scans no more pixels than running them apart (the HOG
detector's time goes with the pixels it scans); a search inside a run already made on the
frame is answered from it. Only searches on one image share runs (several people's heads, or
hands); a hand looks at its own, brightened colour image. Each search gets the faces of its
run whose centre lies in its own rectangle. A search run alone runs exactly as before the
finder existed (:meth:`~human_tracker.vision.faces.detector.FaceDetector.detect_near`, or the whole
frame upsampled once), so one target's faces do not change.

With a thread the runs of frame k go on while frame k + 1 arrives (:meth:`FaceFinder.submit`
at the end of the frame); without one, or when a target waits for its own faces, a search
runs when its faces are asked for.
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import partial

import cv2
import numpy as np

from human_tracker.vision.faces.detector import PYRAMID_STEP, Detection, FaceDetector, near_region
from human_tracker.vision.geometry.boxes import Box, centre_within

__all__ = [
    'FINE_WHOLE_FRAME_ZOOM',
    'SMALLEST_FACE_IN_FRAME',
    'WHOLE_FRAME_ZOOM',
    'FaceFinder',
    'Found',
    'Search',
    'plan_runs',
]

WHOLE_FRAME_ZOOM = 2.0
"""The zoom of the whole-frame search: the frame upsampled once, faces from about 40 px."""
SMALLEST_FACE_IN_FRAME = 40.0
"""The whole-frame search finds faces from about this wide (working pixels)."""
FINE_WHOLE_FRAME_ZOOM = 4.0
"""The zoom of the search for faces smaller than that: from about 20 px, four times the pixels."""

Rectangle = tuple[int, int, int, int]
"""(left, top, right, bottom), working pixels."""


@dataclass(frozen=True)
class Search:
    """Where one target looks for faces on a frame.

    Attributes:
        rectangle: (left, top, right, bottom) of the working frame searched.
        zoom: The crop is resized by this before the detector runs (unupsampled); the whole
            frame's search is :data:`WHOLE_FRAME_ZOOM`.
        near: The face box (x, y, w, h) and reach a search around a face was made from (how it
            runs alone); None for the whole frame.
        shared: Whether its run may merge with other searches and answer them. The search for
            small faces runs alone: at its zoom the detector's pyramid gives the faces the other
            targets look for other boxes, and their tracks would change with it.
    """

    rectangle: Rectangle
    zoom: float
    near: tuple[Box, float] | None = None
    shared: bool = True

    @property
    def cost(self) -> float:
        """Pixels the detector scans: the rectangle's area times the zoom squared."""
        left, top, right, bottom = self.rectangle
        return (right - left) * (bottom - top) * self.zoom**2

    def contains(self, other: Search) -> bool:
        """Whether a run of this search finds every face ``other`` would: its rectangle holds the
        other's, at a zoom at least the other's."""
        if not (self.shared and other.shared):
            return self == other
        (l0, t0, r0, b0), (l1, t1, r1, b1) = self.rectangle, other.rectangle
        return l0 <= l1 and t0 <= t1 and r0 >= r1 and b0 >= b1 and self.zoom >= other.zoom

    def holds(self, face: Detection) -> bool:
        """Whether ``face``'s centre lies in the rectangle."""
        x, y, w, h = face.box
        left, top, right, bottom = self.rectangle
        return left <= x + w / 2 < right and top <= y + h / 2 < bottom


def _merged(a: Search, b: Search) -> Search:
    """One search covering ``a`` and ``b``: their bounding rectangle at the larger zoom."""
    (l0, t0, r0, b0), (l1, t1, r1, b1) = a.rectangle, b.rectangle
    return Search((min(l0, l1), min(t0, t1), max(r0, r1), max(b0, b1)), max(a.zoom, b.zoom))


def plan_runs(searches: Sequence[Search], frame: Rectangle) -> list[tuple[Search, list[int]]]:
    """The runs that answer ``searches`` on a frame, each with the indices of the searches it
    answers: a search inside another (:meth:`Search.contains`) is answered by it, and two
    whose zooms are within one step of the detector's image pyramid merge while the merged
    one costs no more than both (:attr:`Search.cost`).
    A run that covers the whole ``frame`` at :data:`WHOLE_FRAME_ZOOM` or less is the whole-frame
    search."""
    runs = [(search, [i]) for i, search in enumerate(searches)]
    while True:
        best = None
        for i in range(len(runs)):
            for j in range(i + 1, len(runs)):
                (a, _), (b, _) = runs[i], runs[j]
                if not (a.shared and b.shared):
                    continue
                if a.contains(b) or b.contains(a):
                    merged = a if a.contains(b) else b
                elif max(a.zoom, b.zoom) <= PYRAMID_STEP * min(a.zoom, b.zoom):
                    merged = _merged(a, b)
                else:
                    continue  # the larger zoom would look for faces the other search does not
                saving = a.cost + b.cost - merged.cost
                if saving >= 0 and (best is None or saving > best[0]):
                    best = (saving, i, j, merged)
        if best is None:
            break
        _, i, j, merged = best
        if merged.rectangle == frame and merged.zoom <= WHOLE_FRAME_ZOOM:
            merged = Search(frame, WHOLE_FRAME_ZOOM)
        runs[i] = (merged, runs[i][1] + runs[j][1])
        del runs[j]
    return runs


@dataclass
class Found:
    """A search's faces: ready once its run is made (:meth:`result`)."""

    finder: FaceFinder
    search: Search
    grey: np.ndarray
    smaller: Found | None = None
    _faces: Future[list[Detection]] | None = field(default=None, repr=False)
    _run: Search | None = field(default=None, repr=False)

    def result(self) -> list[Detection]:
        """The faces of the search (working pixels, best first), then those of ``smaller`` (the
        search for faces under :data:`SMALLEST_FACE_IN_FRAME`) not already among them; submits
        the searches held until now first."""
        if self._faces is None:
            self.finder.submit()
        assert self._faces is not None
        faces = self._faces.result()
        faces = faces if self._run is self.search else [face for face in faces if self.search.holds(face)]
        if self.smaller is None:
            return faces
        small = [f for f in self.smaller.result() if f.box[2] < SMALLEST_FACE_IN_FRAME]
        return faces + [f for f in small if not any(centre_within(f.box, face.box) for face in faces)]

    def answer(self, run: Search, faces: Future[list[Detection]]) -> None:
        """Take ``faces``, those of ``run``, for this search's."""
        self._run, self._faces = run, faces


@dataclass
class _Frame:
    """A working image, its grey version and the runs made on it."""

    image: np.ndarray
    grey: np.ndarray
    made: list[tuple[Search, Future[list[Detection]]]] = field(default_factory=list)


@dataclass
class FaceFinder:
    """One face detector, its thread, and the searches of every target that shares it.

    Args:
        detector: The detector.
        thread: Run the detector in a thread of its own (``detector_thread``).

    Attributes:
        hold: Keep the searches asked for until :meth:`submit` (a later target of the frame
            may ask too); False starts each as it is asked for.
    """

    detector: FaceDetector
    thread: bool = True
    hold: bool = False
    _worker: ThreadPoolExecutor | None = field(default=None, init=False, repr=False)
    _held: list[Found] = field(default_factory=list, init=False, repr=False)
    # This frame's working images (targets with other working frames look at other images).
    _frames: list[_Frame] = field(default_factory=list, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.thread:
            self._worker = ThreadPoolExecutor(1, 'face_detector')

    @property
    def threaded(self) -> bool:
        """Whether runs go on in the detector's thread."""
        return self._worker is not None

    def new_frame(self) -> None:
        """A new frame begins: no search of it is answered from the runs made before."""
        self.submit()
        self._frames = []

    def grey(self, image: np.ndarray) -> np.ndarray:
        """The grey-level version of the working ``image`` the detector runs on, converted once
        per frame."""
        return self._frame(image).grey

    def near(self, image: np.ndarray, box: Box, reach: float) -> Found:
        """Ask for the faces within ``reach`` face sizes of the face ``box`` (x, y, w, h) on the
        working ``image`` (:meth:`~human_tracker.vision.faces.detector.FaceDetector.detect_near`)."""
        grey = self.grey(image)
        rectangle, zoom = near_region(grey.shape, box, reach)
        return self._ask(Found(self, Search(rectangle, zoom, (box, reach)), grey))

    def whole(self, image: np.ndarray, small_faces: bool = False) -> Found:
        """Ask for the faces on the whole working ``image`` (upsampled once: from about 40 px);
        with ``small_faces``, also for the smaller ones, at :data:`FINE_WHOLE_FRAME_ZOOM` in a
        run of their own (the other searches' faces stay as they were)."""
        grey = self.grey(image)
        height, width = grey.shape
        found = self._ask(Found(self, Search((0, 0, width, height), WHOLE_FRAME_ZOOM), grey))
        if small_faces:
            fine = Search((0, 0, width, height), FINE_WHOLE_FRAME_ZOOM, shared=False)
            found.smaller = self._ask(Found(self, fine, grey))
        return found

    def submit(self) -> None:
        """Start the runs that answer the searches held (in the thread, or here without one):
        a search inside a run already made on its frame is answered from it, the others are
        run as :func:`plan_runs` merges them."""
        held, self._held = self._held, []
        for frame in self._frames:
            asked = [found for found in held if found.grey is frame.grey]
            for found in asked:
                made = next(((run, faces) for run, faces in frame.made if run.contains(found.search)), None)
                if made is not None:
                    found.answer(*made)
            pending = [found for found in asked if found._faces is None]
            height, width = frame.grey.shape
            for search, members in plan_runs([found.search for found in pending], (0, 0, width, height)):
                run = search if len(members) > 1 else pending[members[0]].search
                faces = self._start(frame.grey, run)
                frame.made.append((run, faces))
                for i in members:
                    pending[i].answer(run, faces)

    def localise(self, grey: np.ndarray, box: Box) -> Box:
        """``box``, a face found on ``grey``, found again precisely
        (:meth:`~human_tracker.vision.faces.detector.FaceDetector.localise`), in the detector's thread."""
        if self._worker is None:
            return self.detector.localise(grey, box)
        return self._worker.submit(self.detector.localise, grey, box).result()

    def _frame(self, image: np.ndarray) -> _Frame:
        # Only targets that work on one image share runs: a hand's is the colour frame
        # brightened, and a hand answered on a head's grey one lost precision
        # (docs/decisions/one-face-detector.md).
        for frame in self._frames:
            if frame.image is image:
                return frame
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        self._frames.append(_Frame(image, grey))
        return self._frames[-1]

    def _ask(self, found: Found) -> Found:
        self._held.append(found)
        if not self.hold:
            self.submit()
        return found

    def _start(self, grey: np.ndarray, search: Search) -> Future[list[Detection]]:
        """Run ``search`` on ``grey`` (as one target's search alone runs when it is one)."""
        if search.near is not None:
            box, reach = search.near
            run = partial(self.detector.detect_near, grey, box, reach=reach)
        elif search.zoom == WHOLE_FRAME_ZOOM and search.rectangle == (0, 0, grey.shape[1], grey.shape[0]):
            run = partial(self.detector.detect, grey, upsample=1)
        else:
            run = partial(self.detector.detect_region, grey, search.rectangle, search.zoom)
        if self._worker is not None:
            return self._worker.submit(run)
        done: Future[list[Detection]] = Future()
        done.set_result(run())
        return done
