"""Faces: the detector, each target's search schedule and the one finder that runs every
target's searches of a frame, the face placed on the head, the box found by its look, and
where a head faces.
"""

from __future__ import annotations

from human_tracker.vision.faces.anchoring import BoxAnchor, FacePlace
from human_tracker.vision.faces.box_look import BoxLook
from human_tracker.vision.faces.detector import Detection, FaceDetector, face_detector_available
from human_tracker.vision.faces.facing import Facing
from human_tracker.vision.faces.finder import FaceFinder
from human_tracker.vision.faces.parameters import FaceParameters
from human_tracker.vision.faces.schedule import FaceSchedule

__all__ = [
    'BoxAnchor',
    'BoxLook',
    'Detection',
    'FaceDetector',
    'FaceFinder',
    'FaceParameters',
    'FacePlace',
    'FaceSchedule',
    'Facing',
    'face_detector_available',
]
