"""YuNet (Shiqi Yu's libfacedetection network, as OpenCV's model zoo publishes it, MIT licence):
a small CNN that gives each face a box, a score in [0, 1] and five landmarks, from faces about
10 px wide. Its model file ships in the package (``human_tracker/data/``, with its licence and
provenance); nothing is downloaded at run time. It runs on ``onnxruntime`` with one thread, the
same on a virtualenv's OpenCV 5 and a robot's apt OpenCV 4.6 (whose DNN module cannot load this
model); the network's outputs are decoded here as OpenCV's ``cv2.FaceDetectorYN`` decodes them
(``test_face_detector.py`` compares the two). Its cost and what it finds against dlib's HOG
detector: ``../shared/notes/face-detection.md``.

Not yet the tracker's face evidence (dlib's detector is, :mod:`~human_tracker.vision.faces.detector`):
swapped in, it traded sequences (docs/decisions/yunet-faces.md).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from human_tracker.vision.faces.detector import Detection, near_region
from human_tracker.vision.faces.pose import view_of

__all__ = ['MIN_SCORE', 'MODEL_FILE', 'YuNetDetector', 'yunet_available']

MODEL_FILE = Path(__file__).resolve().parents[2] / 'data' / 'face_detection_yunet_2026may.onnx'
"""YuNet's network (OpenCV zoo, 2026 release; ``data/face_detection_yunet.md`` says where from)."""

# A region searched around a face is resized so that the face is about this wide: YuNet finds
# faces from about 10 px, and a region of four face widths stays a few thousand pixels.
DETECTABLE_FACE = 48.0
# The network's output strides (pixels per output cell); the input's sides are multiples of the largest.
STRIDES = (8, 16, 32)
# The least score of a face (chosen on the real sequences: docs/decisions/yunet-faces.md).
MIN_SCORE = 0.7
# Boxes overlapping a better one by more than this (intersection over union) are the same face.
SAME_FACE_OVERLAP = 0.3


def yunet_available() -> bool:
    """Whether onnxruntime can be imported and the model file is in place."""
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        return False
    return MODEL_FILE.is_file()


class YuNetDetector:
    """YuNet on BGR or grey-level frames, through onnxruntime on one thread.

    Args:
        min_score: Detections scoring below this (in [0, 1]) are dropped.

    Raises:
        ImportError: onnxruntime is not installed.
    """

    def __init__(self, min_score: float = MIN_SCORE) -> None:
        import onnxruntime

        self._runtime = onnxruntime
        self._session: object | None = None
        self.min_score = min_score

    def load(self) -> object:
        """The network's session, made on first use: a node answering ``--help`` does not wait
        for it, and a node's warm-up calls this before its first frame."""
        if self._session is None:
            options = self._runtime.SessionOptions()
            # One thread: the tracker's own threads share the machine's cores with it.
            options.intra_op_num_threads = 1
            options.inter_op_num_threads = 1
            options.log_severity_level = 3
            self._session = self._runtime.InferenceSession(str(MODEL_FILE), options, providers=['CPUExecutionProvider'])
        return self._session

    def detect(self, image: np.ndarray) -> list[Detection]:
        """Faces in ``image`` ``(H, W) uint8`` (grey) or ``(H, W, 3)`` (BGR), boxes and landmarks
        in its pixels, best first."""
        if image.ndim == 2:
            image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        height, width = image.shape[:2]
        if height < 8 or width < 8:
            return []
        step = STRIDES[-1]
        padded_h, padded_w = -(-height // step) * step, -(-width // step) * step
        blob = np.zeros((1, 3, padded_h, padded_w), np.float32)
        blob[0, :, :height, :width] = image.transpose(2, 0, 1)
        names = [f'{kind}_{stride}' for stride in STRIDES for kind in ('cls', 'obj', 'bbox', 'kps')]
        outputs = dict(zip(names, self.load().run(names, {'input': blob}), strict=True))
        return _decode(outputs, padded_w, self.min_score)

    def detect_near(
        self, image: np.ndarray, box: tuple[float, float, float, float], reach: float = 2.0, zoom_factor: float = 1.0
    ) -> list[Detection]:
        """Faces within ``reach`` times the face ``box``'s size (x, y, w, h) of its centre.

        The region (:func:`~human_tracker.vision.faces.detector.near_region`'s) is resized so that
        a face of ``box``'s size is :data:`DETECTABLE_FACE` wide (times ``zoom_factor``): a
        fraction of a whole frame's time.
        """
        rectangle, _ = near_region(image.shape, box, reach)
        zoom = zoom_factor * DETECTABLE_FACE / max(min(box[2], box[3]), 1.0)
        return self.detect_region(image, rectangle, zoom)

    def detect_region(self, image: np.ndarray, rectangle: tuple[int, int, int, int], zoom: float) -> list[Detection]:
        """Faces in the ``rectangle`` (left, top, right, bottom) of ``image`` resized by ``zoom``,
        boxes and landmarks in ``image``'s pixels; none in a rectangle under 8 px."""
        left, top, right, bottom = rectangle
        if right - left < 8 or bottom - top < 8:
            return []
        crop = image[top:bottom, left:right]
        if zoom != 1.0:
            interpolation = cv2.INTER_LINEAR if zoom > 1.0 else cv2.INTER_AREA
            crop = cv2.resize(crop, None, fx=zoom, fy=zoom, interpolation=interpolation)
        return [
            d._replace(
                box=(left + bx / zoom, top + by / zoom, bw / zoom, bh / zoom),
                landmarks=tuple((left + px / zoom, top + py / zoom) for px, py in d.landmarks),
            )
            for d in self.detect(crop)
            for bx, by, bw, bh in [d.box]
        ]


def _decode(outputs: dict[str, np.ndarray], padded_width: int, min_score: float) -> list[Detection]:
    """YuNet's outputs for an input ``padded_width`` wide as detections scoring ``min_score`` or
    more, one per face (non-maximum suppression), best first: per output cell (row r, column c)
    at each stride s, score sqrt(cls * obj), centre ((c, r) + offset) * s, size exp(log size) * s,
    landmarks ((c, r) + offset) * s, as OpenCV's FaceDetectorYN decodes them."""
    boxes, scores, marks = [], [], []
    for stride in STRIDES:
        cls = np.clip(outputs[f'cls_{stride}'].reshape(-1), 0.0, 1.0)
        obj = np.clip(outputs[f'obj_{stride}'].reshape(-1), 0.0, 1.0)
        score = np.sqrt(cls * obj)
        cells = np.flatnonzero(score >= min_score)
        if not cells.size:
            continue
        rows, cols = np.divmod(cells, padded_width // stride)
        offsets = outputs[f'bbox_{stride}'].reshape(-1, 4)[cells]
        size = np.exp(offsets[:, 2:]) * stride
        centre = (np.stack([cols, rows], axis=1) + offsets[:, :2]) * stride
        boxes.append(np.hstack([centre - size / 2, size]))
        points = outputs[f'kps_{stride}'].reshape(-1, 5, 2)[cells]
        marks.append((points + np.stack([cols, rows], axis=1)[:, None, :]) * stride)
        scores.append(score[cells])
    if not boxes:
        return []
    box_array, score_array, mark_array = np.vstack(boxes), np.concatenate(scores), np.vstack(marks)
    kept = cv2.dnn.NMSBoxes(box_array.tolist(), score_array.tolist(), min_score, SAME_FACE_OVERLAP)
    found = []
    for k in np.asarray(kept, dtype=int).reshape(-1):
        landmarks = tuple((float(x), float(y)) for x, y in mark_array[k])
        box = tuple(float(v) for v in box_array[k])
        found.append(Detection(box, float(score_array[k]), view=view_of(landmarks), landmarks=landmarks))  # type: ignore[arg-type]
    return sorted(found, key=lambda d: -d.score)
