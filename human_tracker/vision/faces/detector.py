"""Face detections for the head tracker's proposals (:mod:`~human_tracker.vision.filter.proposals`).

The detector is dlib's HOG frontal-face detector: its model is built into the library (the
``dlib-bin`` wheel, or Ubuntu's ``python3-dlib`` on a robot), so nothing is downloaded at run
time, and it does not depend on OpenCV's version (OpenCV 5's wheel ships no cascades; its
DNN face detectors need model files). Measured here: 7-26 ms on a 320x240 frame, finding
faces from about 40 px wide when the frame is upsampled once (``../shared/notes``). To fit
the speed budget the tracker runs it every few frames, on a crop around the predicted head
while it tracks and on the whole working frame while it searches.
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from human_tracker.vision.geometry.boxes import BoxRelation

__all__ = ['FACE_ON_HEAD', 'Detection', 'FaceDetector', 'face_detector_available', 'near_region']

# Where dlib's face box sits on the head-and-shoulders contour (template units: the head is
# one unit wide, centred on the origin): eyebrows to chin, a little below the head's centre.
FACE_ON_HEAD = BoxRelation(centre=(0.0, 0.12), size=(0.8, 0.8))

# dlib finds faces of about 80 px and up without upsampling.
DETECTABLE_FACE = 80.0
# dlib's image pyramid shrinks the image by 5/6 from one level to the next.
PYRAMID_STEP = 1.2


class Detection(NamedTuple):
    """One detected face.

    Attributes:
        box: ``(x, y, w, h)`` pixels of the image given to the detector.
        score: The detector's confidence (SVM margin; > 0 is a face).
        carried: ``(dx, dy)`` pixels the box was moved from where the detector found it: a
            face found on an earlier frame, carried to where it is expected on this one.
        view: Which of dlib's filters found it: 0 a face looking toward the camera, 1 and 2
            looking to its left and right, 3 and 4 toward the camera, turned in the image.
        landmarks: Five ``(x, y)`` points, pixels as ``box``, from a detector that gives them
            (:mod:`~human_tracker.vision.faces.yunet`): the eyes (the person's right, then
            left), the nose tip, the mouth's corners; empty from dlib's.
    """

    box: tuple[float, float, float, float]
    score: float
    carried: tuple[float, float] = (0.0, 0.0)
    view: int = 0
    landmarks: tuple[tuple[float, float], ...] = ()


def face_detector_available() -> bool:
    """Whether dlib can be imported."""
    try:
        import dlib  # noqa: F401
    except ImportError:
        return False
    return True


class FaceDetector:
    """dlib's HOG frontal-face detector on grey-level frames.

    Args:
        min_score: Detections scoring below this are dropped.

    Raises:
        ImportError: dlib is not installed.
    """

    def __init__(self, min_score: float = 0.0) -> None:
        import dlib

        self._dlib = dlib
        self._model: object | None = None
        self.min_score = min_score
        # Local contrast: a face in shadow against a bright sky (trellis) has too little
        # gradient for the HOG; equalised in tiles it is found twice as often there, and
        # with the clip limit at 4 rather than 2 on 102 rather than 88 of 143 sampled
        # frames (the other real sequences: within 2 either way). Trellis, 10 seeds, from the
        # box 0.921 -> 0.955, without 0.853 -> 0.931.
        self._contrast = cv2.createCLAHE(clipLimit=4.0, tileGridSize=(4, 4))

    def load(self) -> object:
        """dlib's detector, built on first use (0.4 s): a node answering ``--help`` does not wait
        for it, and a node's warm-up calls this before its first frame."""
        if self._model is None:
            self._model = self._dlib.get_frontal_face_detector()
        return self._model

    def detect(self, image: np.ndarray, upsample: int = 1) -> list[Detection]:
        """Faces in ``image`` ``(H, W) uint8`` (or BGR), boxes in its pixels, best first.

        ``upsample`` doubles the image this many times first: faces from about 40 px are found
        with 1, from 80 px with 0 (four times faster).
        """
        if image.ndim == 3:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        rectangles, scores, views = self.load().run(self._contrast.apply(image), upsample, self.min_score)
        found = [
            Detection((float(r.left()), float(r.top()), float(r.width()), float(r.height())), float(score), view=int(v))
            for r, score, v in zip(rectangles, scores, views, strict=True)
        ]
        return sorted(found, key=lambda d: -d.score)

    def detect_near(
        self, image: np.ndarray, box: tuple[float, float, float, float], reach: float = 2.0, zoom_factor: float = 1.0
    ) -> list[Detection]:
        """Faces within ``reach`` times the face ``box``'s size (x, y, w, h) of its centre.

        The region is resized so that a face of ``box``'s size is just detectable without
        upsampling (times ``zoom_factor``): a few milliseconds instead of a whole frame's
        tens, and faces smaller than the whole-frame search finds.
        """
        rectangle, zoom = near_region(image.shape, box, reach, zoom_factor)
        return self.detect_region(image, rectangle, zoom)

    def detect_region(self, image: np.ndarray, rectangle: tuple[int, int, int, int], zoom: float) -> list[Detection]:
        """Faces in the ``rectangle`` (left, top, right, bottom) of ``image`` resized by ``zoom``
        (not upsampled further), boxes in ``image``'s pixels; none in a rectangle under 8 px."""
        left, top, right, bottom = rectangle
        if right - left < 8 or bottom - top < 8:
            return []
        crop = image[top:bottom, left:right]
        interpolation = cv2.INTER_LINEAR if zoom > 1.0 else cv2.INTER_AREA
        crop = cv2.resize(crop, None, fx=zoom, fy=zoom, interpolation=interpolation)
        return [
            d._replace(box=(left + bx / zoom, top + by / zoom, bw / zoom, bh / zoom))
            for d in self.detect(crop, upsample=0)
            for bx, by, bw, bh in [d.box]
        ]

    def localise(
        self, image: np.ndarray, face: tuple[float, float, float, float], zooms: int = 5, reach: float = 1.0
    ) -> tuple[float, ...]:
        """The ``face`` box (x, y, w, h) found again at ``zooms`` zooms across one step of the
        detector's scale pyramid, within ``reach`` face sizes of its centre, the median of those
        that overlap it (itself included).

        A HOG detector's box is quantised by its cells and pyramid levels: the same face found
        in two crops of slightly different scale moves by a tenth of its width. Where one box
        is remembered for the rest of a track (how a start box sits on the face), the median
        removes most of that jitter. Only the face itself is looked for (``reach`` 1: a region
        twice its size, not a head's search region around it): the frame a track takes its
        first face on waits for these runs
        (docs/decisions/first-face-localised-around-itself.md).
        """
        boxes = [face]
        for factor in np.geomspace(PYRAMID_STEP**-0.5, PYRAMID_STEP**0.5, zooms):
            found = self.detect_near(image, face, reach, float(factor))
            best = max(found, key=lambda d: _overlap(d.box, face), default=None)
            if best is not None and _overlap(best.box, face) > 0.5:
                boxes.append(best.box)
        return tuple(float(v) for v in np.median(np.array(boxes), axis=0))


def near_region(
    shape: tuple[int, ...], box: tuple[float, float, float, float], reach: float = 2.0, zoom_factor: float = 1.0
) -> tuple[tuple[int, int, int, int], float]:
    """The rectangle (left, top, right, bottom) of an image of ``shape`` within ``reach`` times
    the face ``box``'s size (x, y, w, h) of its centre, and the zoom at which a face of ``box``'s
    size is just detectable there without upsampling (times ``zoom_factor``)."""
    x, y, w, h = box
    size = reach * max(w, h)
    height, width = shape[:2]
    left, top = int(max(0, x + w / 2 - size)), int(max(0, y + h / 2 - size))
    right, bottom = int(min(width, x + w / 2 + size)), int(min(height, y + h / 2 + size))
    return (left, top, right, bottom), zoom_factor * DETECTABLE_FACE / max(min(w, h) * 0.9, 1.0)


def _overlap(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    """Intersection over union of two (x, y, w, h) boxes."""
    width = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    height = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    inter = max(width, 0.0) * max(height, 0.0)
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)
