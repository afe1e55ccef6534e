"""The standard outputs' messages (TF, REP-155, vision_msgs) and the interfaces they are built on:
the same on the wire as a robot's apt packages, declared for rosdep."""

from __future__ import annotations

import importlib
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO
from geometry_msgs.msg import PoseWithCovariance
from scipy.spatial.transform import Rotation
from std_msgs.msg import Header

from human_tracker.ros.standard_outputs import (
    PublishedTarget,
    detection_2d,
    detection_3d,
    face_orientation,
    frame_name,
    normalised_region,
    target_name,
)
from human_tracker.vision.faces.facing import Facing

# RIHS01 type hashes of the upstream definitions a Jazzy robot's apt packages are built from:
# ros2/geometry2 jazzy 646342c6 (tf2_msgs 0.36.4), ros4hri/hri_msgs humble-devel 4e7c1765
# (2.0.0), ros-perception/vision_msgs ros2 e77fa2d9 (4.1.1); computed by rosidl from those files.
# The hash covers every field's name and type, nested types included: a subscriber of the
# robot's own type matches ours only if they are equal.
UPSTREAM_TYPE_HASHES = {
    ('tf2_msgs', 'TFMessage'): 'e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087',
    ('hri_msgs', 'Gesture'): 'fbf9f3c4cb8a64e63a1cf819affbb09a32915da45d4786c701eed225193b7f4a',
    ('hri_msgs', 'IdsList'): '7e0812d1ac945c98fd3e393568d581ad0ab567f37b24eff633eab778c1bfe62d',
    ('hri_msgs', 'IdsMatch'): '1c649d4a87ca2d4fe5f606395e83a863640e411c9192dfda6d399a68019966f0',
    ('hri_msgs', 'NormalizedRegionOfInterest2D'): '2e50c93f1ca166ee77af9a5424dc951ae4e452b740162a7f83c082d917dcaff5',
    ('vision_msgs', 'BoundingBox2D'): '008eacbb0cf8f26e83795547bed013eec3675485ef386ec056d80eaaf1c1ce2f',
    ('vision_msgs', 'BoundingBox3D'): 'bbb73a65c163d7f9bb29009c7bde9f7faa576bd2d23299c4511d19230dab4698',
    ('vision_msgs', 'Detection2D'): '0d12b69df5c593b3455b7346fac8205437a7d4bcb09b9e0e0b2dde787ded38ea',
    ('vision_msgs', 'Detection2DArray'): '214274120007f4a683866481336b70310268cfa107aebe9d594a6acf75bda968',
    ('vision_msgs', 'Detection3D'): 'ddd703be132ab0b69d33121f1bb034132bfbb3b0ac5f9fb1516005ba1c8a265b',
    ('vision_msgs', 'Detection3DArray'): '793f5eab9595ac1c0da07873cc859db42eae51f0ee76056db8562515d830e018',
    ('vision_msgs', 'ObjectHypothesis'): '51da43cec11c01957a64d1e05a24acd18aae7745ec30b74348ad5f6d634f7f90',
    ('vision_msgs', 'ObjectHypothesisWithPose'): '41c12344c0396c48b81df12467c192d99b2a0eb1463c5c37194e4223251c80bc',
    ('vision_msgs', 'Point2D'): 'eab0e83f44ab4de92ceaf76dd7d0e7638f2bdd1d16ffbe16c7a136c48e407247',
    ('vision_msgs', 'Pose2D'): 'b0b5d1d7b4c20dd4fcde3ed1d4b289a919290572007d67a97043814db25d3648',
}


@pytest.mark.parametrize(('package', 'message'), sorted(UPSTREAM_TYPE_HASHES))
def test_each_interface_is_the_upstream_type_on_the_wire(package: str, message: str) -> None:
    """The installed type (the virtualenv's build of ``interfaces/``, or apt's on a robot) has
    the upstream definition's type hash."""
    # <prefix>/lib/pythonX.Y/site-packages/<package>: the package's share is <prefix>/share/<package>.
    prefix = Path(importlib.import_module(package).__file__).parents[4]
    description = prefix / 'share' / package / 'msg' / f'{message}.json'
    hashes = json.loads(description.read_text())['type_hashes']
    assert hashes[0]['hash_string'] == f'RIHS01_{UPSTREAM_TYPE_HASHES[package, message]}'


def test_package_xml_declares_the_interfaces_for_rosdep_and_colcon_skips_the_copies() -> None:
    """On a robot rosdep installs the real packages; the copies in interfaces/ are for the
    virtualenv only and colcon must not build them over a robot's (COLCON_IGNORE)."""
    keys = {e.text for e in ET.parse(REPO / 'package.xml').getroot().iter('exec_depend')}
    assert {'tf2_msgs', 'hri_msgs', 'vision_msgs'} <= keys
    assert (REPO / 'interfaces' / 'COLCON_IGNORE').exists()
    built = {p.parent.name for p in (REPO / 'interfaces').glob('*/package.xml')}
    assert built == {package for package, _ in UPSTREAM_TYPE_HASHES}


def test_ids_start_with_a_letter_and_name_the_frames() -> None:
    assert target_name('head', 3) == 'f00003' and target_name('hand', 12) == 'h00012'
    assert frame_name('head', 3) == 'face_f00003'
    assert frame_name('hand', 12, 'robot/') == 'robot/hand_h00012'


def test_the_region_is_the_box_in_image_fractions_clipped_to_the_image() -> None:
    header = Header(frame_id='camera')
    region = normalised_region(header, (64.0, 48.0, 32.0, 24.0), (480, 640), 0.8)
    values = (region.xmin, region.ymin, region.xmax, region.ymax, region.c)
    assert values == pytest.approx((0.1, 0.1, 0.15, 0.15, 0.8))
    outside = normalised_region(header, (-10.0, 470.0, 40.0, 40.0), (480, 640), 0.5)
    assert (outside.xmin, outside.ymax) == (0.0, 1.0)
    assert region.header.frame_id == 'camera'


def _axes(theta: float, facing: Facing | None) -> np.ndarray:
    q = face_orientation(theta, facing)
    return Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()


def test_the_face_frame_looks_out_of_the_face_with_its_z_up() -> None:
    """REP-155's face frame in the optical frame (x right, y down, z forward): a face toward
    the camera looks at it (x along -z), its left is the image's right, its z is up (-y); turned
    away it looks along +z; the silhouette's tilt θ turns it about the optical axis."""
    toward = _axes(0.0, Facing.TOWARD)
    np.testing.assert_allclose(toward, [[0, 1, 0], [0, 0, -1], [-1, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(_axes(0.0, Facing.UNKNOWN), toward, atol=1e-12)
    np.testing.assert_allclose(_axes(0.0, Facing.AWAY)[:, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(_axes(0.0, Facing.AWAY)[:, 2], [0, -1, 0], atol=1e-12)
    tilted = _axes(0.3, Facing.TOWARD)
    np.testing.assert_allclose(tilted[:, 2], [np.sin(0.3), -np.cos(0.3), 0.0], atol=1e-12)
    np.testing.assert_allclose(tilted[:, 0], [0, 0, -1], atol=1e-12)


def test_the_detections_carry_the_box_the_pose_and_the_size() -> None:
    pose = PoseWithCovariance()
    pose.pose.position.x, pose.pose.position.z = 0.1, 1.5
    pose.covariance = [float(v) for v in range(36)]
    target = PublishedTarget(
        id=7,
        kind='hand',
        box=(100.0, 50.0, 40.0, 60.0),
        confidence=0.7,
        pose=pose,
        theta=0.0,
        facing=None,
        size=(0.18, 0.27, 0.02),
    )
    header = Header(frame_id='camera')
    flat = detection_2d(header, target)
    assert flat.id == 'h00007' and flat.results[0].hypothesis.class_id == 'hand'
    assert flat.results[0].hypothesis.score == pytest.approx(0.7)
    assert (flat.bbox.center.position.x, flat.bbox.center.position.y) == (120.0, 80.0)
    assert (flat.bbox.size_x, flat.bbox.size_y) == (40.0, 60.0)
    metric = detection_3d(header, target)
    assert metric.id == 'h00007' and metric.bbox.center.position.z == 1.5
    assert list(metric.results[0].pose.covariance) == pose.covariance.tolist()
    assert (metric.bbox.size.x, metric.bbox.size.y, metric.bbox.size.z) == (0.18, 0.27, 0.02)
