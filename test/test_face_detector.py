"""YuNet, the CNN face detector measured against dlib's (vision/faces/yunet.py), and where a face
looks from its landmarks (vision/faces/pose.py)."""

from __future__ import annotations

import hashlib
import math

import cv2
import numpy as np
import pytest
from conftest import REAL_DATA

from human_tracker.vision.faces.pose import MEAN_FACE, SIDE_YAW, head_orientation, view_of
from human_tracker.vision.faces.yunet import MIN_SCORE, MODEL_FILE, YuNetDetector, yunet_available

MODEL_SHA256 = 'ebafce4e3c118d6554634be5c27ab333b4c047a9a8c3faf1d7cf93101c22f0f0'


def test_the_model_file_is_the_one_its_provenance_names() -> None:
    """The shipped network is the file data/face_detection_yunet.md names, with its licence beside it."""
    assert hashlib.sha256(MODEL_FILE.read_bytes()).hexdigest() == MODEL_SHA256
    provenance = MODEL_FILE.with_name('face_detection_yunet.md').read_text()
    assert MODEL_SHA256 in provenance and MODEL_FILE.name in provenance
    assert MODEL_FILE.with_name('face_detection_yunet.LICENSE').read_text().startswith('MIT License')
    assert yunet_available(), 'onnxruntime is a dependency: pip install onnxruntime (see README)'


def _opencv_runs_the_model() -> bool:
    """Whether this OpenCV's FaceDetectorYN runs the shipped model (OpenCV 4.6's DNN cannot)."""
    try:
        cv2.FaceDetectorYN.create(str(MODEL_FILE), '', (64, 64)).detect(np.zeros((64, 64, 3), np.uint8))
    except (AttributeError, cv2.error):
        return False
    return True


@pytest.mark.skipif(not (REAL_DATA / 'david_colour').is_dir(), reason='real sequences absent')
@pytest.mark.skipif(not _opencv_runs_the_model(), reason="this OpenCV's FaceDetectorYN cannot run the model")
def test_the_decoding_is_opencv_s_own() -> None:
    """Where OpenCV can run the model itself (OpenCV 5; a robot's 4.6 cannot load it), its
    FaceDetectorYN gives the same faces: boxes, landmarks and scores to 1e-3."""
    detector = YuNetDetector()
    compared = 0
    for path in sorted((REAL_DATA / 'david_colour' / 'img').iterdir())[::97]:
        image = cv2.imread(str(path))
        height, width = image.shape[:2]
        reference = cv2.FaceDetectorYN.create(str(MODEL_FILE), '', (width, height), MIN_SCORE, 0.3, 5000)
        found = reference.detect(image)[1]
        expected = [] if found is None else sorted(found.tolist(), key=lambda row: -row[14])
        ours = detector.detect(image)
        assert len(ours) == len(expected), path.name
        for face, row in zip(ours, expected, strict=True):
            np.testing.assert_allclose(face.box, row[:4], atol=1e-3)
            np.testing.assert_allclose(np.ravel(face.landmarks), row[4:14], atol=1e-3)
            assert face.score == pytest.approx(row[14], abs=1e-3)
            compared += 1
    assert compared >= 5


def test_a_crop_is_searched_at_the_zoom_that_makes_its_face_detectable() -> None:
    """A face found in a zoomed crop comes back in the image's pixels, landmarks too: the same
    face found in the whole frame and around it (shrunk to DETECTABLE_FACE) agree within 8 % of
    its width."""
    if not (REAL_DATA / 'interview_alberto').is_dir():
        pytest.skip('real sequences absent')
    image = cv2.imread(str(sorted((REAL_DATA / 'interview_alberto' / 'img').iterdir())[0]))
    detector = YuNetDetector()
    (whole, *_) = detector.detect(image)
    (near, *_) = detector.detect_near(image, whole.box)
    tolerance = 0.08 * whole.box[2]
    np.testing.assert_allclose(near.box, whole.box, atol=tolerance)
    np.testing.assert_allclose(near.landmarks, whole.landmarks, atol=tolerance)


def _landmarks(yaw: float, pitch: float, width: float = 60.0) -> tuple[tuple[float, float], ...]:
    """The mean face turned by ``yaw`` (to the image's right) and ``pitch`` (up), seen by a far
    camera, scaled to about ``width`` pixels eye to eye, centred at (200, 150)."""
    turn = cv2.Rodrigues(np.array([0.0, -yaw, 0.0]))[0] @ cv2.Rodrigues(np.array([-pitch, 0.0, 0.0]))[0]
    points = MEAN_FACE @ turn.T
    points = points + [0.0, 0.0, 2000.0]
    focal = 2000.0 * width / 63.0
    image = focal * points[:, :2] / points[:, 2:] + [200.0, 150.0]
    return tuple((float(x), float(y)) for x, y in image)


@pytest.mark.parametrize(('yaw', 'pitch'), [(0.0, 0.0), (25.0, 0.0), (-50.0, 0.0), (0.0, 15.0), (30.0, -20.0)])
def test_the_pose_of_a_known_face_is_found_again(yaw: float, pitch: float) -> None:
    """Landmarks projected from the mean face at a known yaw and pitch give them back within a degree."""
    orientation = head_orientation(_landmarks(math.radians(yaw), math.radians(pitch)))
    assert orientation is not None
    assert math.degrees(orientation.yaw) == pytest.approx(yaw, abs=1.0)
    assert math.degrees(orientation.pitch) == pytest.approx(pitch, abs=1.0)


def test_the_view_is_side_past_the_side_yaw_and_says_which_side() -> None:
    margin = math.radians(5.0)
    assert view_of(_landmarks(SIDE_YAW - margin, 0.0)) == 0
    assert view_of(_landmarks(SIDE_YAW + margin, 0.0)) == 1
    assert view_of(_landmarks(-SIDE_YAW - margin, 0.0)) == 2
    assert view_of(()) == 0 and head_orientation(()) is None
