"""What a robot's other software already reads, for every TRACKING target of a frame
(:class:`StandardOutputs`):

- **TF** (``/tf``, tf2_msgs/TFMessage, what tf2_ros's broadcaster sends): a frame per target,
  child of the image's ``frame_id`` (its optical frame), named ``face_<id>`` for a head (REP-155)
  and ``hand_<id>`` for a hand, behind an optional prefix. A face frame follows REP-155: x out of
  the face, y to the person's left, z up; a hand frame is the optical frame turned by the
  silhouette's angle θ, as ``pose``. Each face frame has a ``gaze_<id>`` child (REP-155's gaze
  frame: z along the gaze, x to the person's right, y down, as an optical frame), where the head
  looks: the face frame's x.
- **ROS4HRI faces** (REP-155): ``/humans/faces/tracked`` (hri_msgs/IdsList) on every frame,
  and ``/humans/faces/<id>/roi`` (hri_msgs/NormalizedRegionOfInterest2D) per face; an id is
  published once its head has been TRACKING ``confirm_frames`` frames in a row, and leaves the
  list on the first frame it is not.
- **ROS4HRI bodies**, where people are followed with their hands (``bodies``): each published
  face's person is a body, ``b<digits>`` with its face's digits: ``/humans/bodies/tracked``
  (IdsList), a ``body_<id>`` TF frame (at the head, the one place of the body measured; axes as
  the face frame's, upright), the person's gesture on ``/humans/bodies/<id>/gesture``
  (hri_msgs/Gesture, on every frame a gesture is read:
  :mod:`~human_tracker.vision.people.gestures`), and on ``/humans/candidate_matches``
  (hri_msgs/IdsMatch) the face-body match, confidence 1 when the body appears and 0 when it
  goes.
- **vision_msgs**: ``detections`` (Detection2DArray: box, class ``head`` / ``hand``, score the
  confidence, id) and ``detections_3d`` (Detection3DArray: the metric pose and its covariance,
  the target's physical size) on every frame, empty when nothing is TRACKING.

Every id is the track's (:attr:`~human_tracker.vision.track.outcomes.TrackedTarget.id`), written as
:func:`target_name` does: ``f00003`` for a head, ``h00004`` for a hand.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from geometry_msgs.msg import PoseWithCovariance, Quaternion, TransformStamped
from hri_msgs.msg import Gesture as GestureMessage
from hri_msgs.msg import IdsList, IdsMatch, NormalizedRegionOfInterest2D
from rclpy.duration import Duration
from tf2_msgs.msg import TFMessage
from vision_msgs.msg import (
    Detection2D,
    Detection2DArray,
    Detection3D,
    Detection3DArray,
    ObjectHypothesis,
    ObjectHypothesisWithPose,
)

from human_tracker.ros.common import LATCHED_QOS, RESULT_QOS
from human_tracker.vision.faces.facing import Facing
from human_tracker.vision.people.gestures import Gesture

__all__ = [
    'BODIES_TOPIC',
    'FACES_TOPIC',
    'MATCHES_TOPIC',
    'PublishedTarget',
    'StandardOutputs',
    'detection_2d',
    'detection_3d',
    'face_orientation',
    'frame_name',
    'gaze_frame_name',
    'normalised_region',
    'target_name',
]

FACES_TOPIC = '/humans/faces'
"""REP-155's namespace of faces: ``tracked`` and ``<id>/roi`` under it."""

BODIES_TOPIC = '/humans/bodies'
"""REP-155's namespace of bodies: ``tracked`` and ``<id>/gesture`` under it."""

MATCHES_TOPIC = '/humans/candidate_matches'
"""REP-155's matches between ids (here a face and its body)."""

_ID_LETTER = {'head': 'f', 'hand': 'h', 'body': 'b'}
_FRAME_WORD = {'head': 'face', 'hand': 'hand', 'body': 'body'}

# A head turned by ψ about the vertical (the optical y axis) from facing the camera.
_YAW = {Facing.TOWARD: 0.0, Facing.AWAY: np.pi}

# REP-155's face frame of a face looking into the camera, in optical axes (x right, y down,
# z forward): its x (out of the face) is -z, its y (the person's left, the image's right) is
# +x, its z (up) is -y. As a quaternion (x, y, z, w).
_FACING_CAMERA = (0.5, 0.5, -0.5, 0.5)


# REP-155's gaze frame in its face frame: its z (the gaze) is the face's x, its x the face's -y
# (the person's right), its y the face's -z (down). As a quaternion (x, y, z, w).
_GAZE_IN_FACE = (0.5, -0.5, 0.5, -0.5)


def _turn(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, ...]:
    """The rotation ``b`` then ``a``: the Hamilton product of quaternions (x, y, z, w).
    Written out: scipy's rotations cost a third of a second to import, at every node's start."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


class PublishedTarget(NamedTuple):
    """One TRACKING target as the standard outputs publish it.

    Attributes:
        id: The track's id (from 1).
        kind: ``head`` or ``hand``.
        box: Its box (x, y, w, h), the image's pixels.
        confidence: Its estimate's confidence, 0-1.
        pose: Its metric pose and covariance in the optical frame
            (:func:`~human_tracker.ros.tracker_outputs.metric_pose`).
        theta: The silhouette's angle θ about the optical axis, radians.
        facing: Where a head faces; None for a hand.
        size: Its physical width, height and depth, metres.
        gesture: A head's person's gesture (:attr:`Gesture.NONE` for a hand, or none read).
    """

    id: int
    kind: str
    box: tuple[float, float, float, float]
    confidence: float
    pose: PoseWithCovariance
    theta: float
    facing: Facing | None
    size: tuple[float, float, float]
    gesture: Gesture = Gesture.NONE


def target_name(kind: str, ident: int) -> str:
    """The id string of track ``ident`` of ``kind`` (``head``, ``hand``, or ``body``: a head's
    person): a letter and five digits (``f00003``), as REP-155 asks of an id (it starts with a
    letter)."""
    return f'{_ID_LETTER[kind]}{ident:05d}'


def frame_name(kind: str, ident: int, prefix: str = '') -> str:
    """The TF frame of track ``ident``: ``<prefix>face_<id>`` for a head, ``<prefix>hand_<id>`` for a hand."""
    return f'{prefix}{_FRAME_WORD[kind]}_{target_name(kind, ident)}'


def gaze_frame_name(ident: int, prefix: str = '') -> str:
    """The TF frame of head ``ident``'s gaze: ``<prefix>gaze_<id>`` (REP-155), child of its face frame."""
    return f'{prefix}gaze_{target_name("head", ident)}'


def face_orientation(theta: float, facing: Facing | None) -> Quaternion:
    """The orientation in the optical frame of REP-155's face frame of a head tilted by ``theta``
    (radians, about the optical axis, as ``pose``) and turned as ``facing`` says: toward the
    camera, or away (turned by π about the vertical). ``side`` does not say to which side, and
    ``unknown`` nothing: both are given as toward."""
    yaw = _YAW.get(facing, 0.0)
    tilt = (0.0, 0.0, np.sin(theta / 2.0), np.cos(theta / 2.0))
    turn = (0.0, np.sin(yaw / 2.0), 0.0, np.cos(yaw / 2.0))
    x, y, z, w = _turn(tilt, _turn(turn, _FACING_CAMERA))
    return Quaternion(x=float(x), y=float(y), z=float(z), w=float(w))


def normalised_region(
    header: Any, box: tuple[float, float, float, float], shape: tuple[int, ...], confidence: float
) -> NormalizedRegionOfInterest2D:
    """``box`` (x, y, w, h, pixels of an image of ``shape``) as REP-155's region: its corners in
    [0, 1] of the image's width and height (clipped to the image), and ``confidence``."""
    height, width = shape[:2]
    x, y, w, h = box
    return NormalizedRegionOfInterest2D(
        header=header,
        xmin=float(np.clip(x / width, 0.0, 1.0)),
        ymin=float(np.clip(y / height, 0.0, 1.0)),
        xmax=float(np.clip((x + w) / width, 0.0, 1.0)),
        ymax=float(np.clip((y + h) / height, 0.0, 1.0)),
        c=float(confidence),
    )


def _transform(header: Any, child: str, target: PublishedTarget, upright: bool = False) -> TransformStamped:
    """The target's frame ``child`` (a body's, ``upright``: its head's without the head's tilt)."""
    transform = TransformStamped(header=header, child_frame_id=child)
    position = target.pose.pose.position
    transform.transform.translation.x, transform.transform.translation.y = position.x, position.y
    transform.transform.translation.z = position.z
    if target.kind == 'head':
        transform.transform.rotation = face_orientation(0.0 if upright else target.theta, target.facing)
    else:
        transform.transform.rotation = target.pose.pose.orientation
    return transform


def _gaze(header: Any, face: str, ident: int, prefix: str) -> TransformStamped:
    """Head ``ident``'s gaze frame under its ``face`` frame: at its origin, looking along its x."""
    gaze = TransformStamped(child_frame_id=gaze_frame_name(ident, prefix))
    gaze.header.stamp, gaze.header.frame_id = header.stamp, face
    x, y, z, w = _GAZE_IN_FACE
    gaze.transform.rotation = Quaternion(x=x, y=y, z=z, w=w)
    return gaze


def _hypothesis(target: PublishedTarget, pose: PoseWithCovariance | None = None) -> ObjectHypothesisWithPose:
    found = ObjectHypothesisWithPose(hypothesis=ObjectHypothesis(class_id=target.kind, score=target.confidence))
    if pose is not None:
        found.pose = pose
    return found


def detection_2d(header: Any, target: PublishedTarget) -> Detection2D:
    """The target's axis-aligned box (pixels, θ of the box 0) with its class and score."""
    detection = Detection2D(header=header, id=target_name(target.kind, target.id), results=[_hypothesis(target)])
    x, y, w, h = target.box
    detection.bbox.center.position.x, detection.bbox.center.position.y = x + w / 2.0, y + h / 2.0
    detection.bbox.size_x, detection.bbox.size_y = float(w), float(h)
    return detection


def detection_3d(header: Any, target: PublishedTarget) -> Detection3D:
    """The target's metric pose (with covariance) and physical size."""
    detection = Detection3D(
        header=header, id=target_name(target.kind, target.id), results=[_hypothesis(target, target.pose)]
    )
    detection.bbox.center = target.pose.pose
    detection.bbox.size.x, detection.bbox.size.y, detection.bbox.size.z = target.size
    return detection


class StandardOutputs:
    """The TF, REP-155 and vision_msgs publishers of a tracker node, and the faces' ids between frames.

    Args:
        node: The node that publishes.
        tf: Publish the targets' frames on ``/tf``.
        faces: Publish REP-155's ``/humans/faces`` topics.
        frame_prefix: Put before every TF child frame's name.
        confirm_frames: Frames a head is TRACKING in a row before its face id is published.
        bodies: Publish REP-155's ``/humans/bodies`` topics and the face-body matches (people
            followed with their hands; with ``faces``).
    """

    def __init__(
        self, node: Any, *, tf: bool, faces: bool, frame_prefix: str, confirm_frames: int, bodies: bool = False
    ) -> None:
        self.node = node
        self.frame_prefix = frame_prefix
        self.confirm_frames = confirm_frames
        self.tf_pub = node.create_publisher(TFMessage, '/tf', RESULT_QOS) if tf else None
        # Latched: a client that subscribes once it sees an id gets that face's region at once.
        self.tracked_pub = node.create_publisher(IdsList, f'{FACES_TOPIC}/tracked', LATCHED_QOS) if faces else None
        self.detections_pub = node.create_publisher(Detection2DArray, 'detections', RESULT_QOS)
        self.detections_3d_pub = node.create_publisher(Detection3DArray, 'detections_3d', RESULT_QOS)
        self.frames_tracking: dict[int, int] = {}  # per head's id: frames TRACKING in a row
        self.region_pubs: dict[str, Any] = {}  # per published face id: its roi publisher
        self.bodies_pub = self.matches_pub = None
        if faces and bodies:
            self.bodies_pub = node.create_publisher(IdsList, f'{BODIES_TOPIC}/tracked', LATCHED_QOS)
            self.matches_pub = node.create_publisher(IdsMatch, MATCHES_TOPIC, RESULT_QOS)
        self.gesture_pubs: dict[str, Any] = {}  # per published body id: its gesture publisher

    def publish(self, header: Any, shape: tuple[int, ...], targets: list[PublishedTarget]) -> None:
        """Every output of one frame whose TRACKING targets are ``targets`` (image of ``shape``)."""
        if self.tf_pub is not None and targets:
            transforms = []
            for target in targets:
                name = frame_name(target.kind, target.id, self.frame_prefix)
                transforms.append(_transform(header, name, target))
                if target.kind == 'head':
                    transforms.append(_gaze(header, name, target.id, self.frame_prefix))
                    if self.bodies_pub is not None:
                        body = frame_name('body', target.id, self.frame_prefix)
                        transforms.append(_transform(header, body, target, upright=True))
            self.tf_pub.publish(TFMessage(transforms=transforms))
        flat = Detection2DArray(header=header, detections=[detection_2d(header, t) for t in targets])
        self.detections_pub.publish(flat)
        metric = Detection3DArray(header=header, detections=[detection_3d(header, t) for t in targets])
        self.detections_3d_pub.publish(metric)
        if self.tracked_pub is not None:
            self._publish_faces(header, shape, [t for t in targets if t.kind == 'head'])

    def _publish_faces(self, header: Any, shape: tuple[int, ...], heads: list[PublishedTarget]) -> None:
        self.frames_tracking = {h.id: self.frames_tracking.get(h.id, 0) + 1 for h in heads}
        confirmed = [h for h in heads if self.frames_tracking[h.id] >= self.confirm_frames]
        names = [target_name('head', h.id) for h in confirmed]
        self._keep_regions(names)
        for name, head in zip(names, confirmed, strict=True):
            if name not in self.region_pubs:
                topic = f'{FACES_TOPIC}/{name}/roi'
                self.region_pubs[name] = self.node.create_publisher(NormalizedRegionOfInterest2D, topic, LATCHED_QOS)
            self.region_pubs[name].publish(normalised_region(header, head.box, shape, head.confidence))
        self.tracked_pub.publish(IdsList(header=header, ids=names))
        if self.bodies_pub is not None:
            self._publish_bodies(header, confirmed)

    def _publish_bodies(self, header: Any, heads: list[PublishedTarget]) -> None:
        """Each confirmed face's body: its id on ``tracked``, its match to the face when it
        appears, its person's gesture while one is read."""
        bodies = {target_name('body', h.id): h for h in heads}
        self._keep_bodies(list(bodies))
        for body, head in bodies.items():
            if body not in self.gesture_pubs:
                topic = f'{BODIES_TOPIC}/{body}/gesture'
                self.gesture_pubs[body] = self.node.create_publisher(GestureMessage, topic, LATCHED_QOS)
                self._match(body, 1.0)
            if head.gesture is not Gesture.NONE:
                self.gesture_pubs[body].publish(GestureMessage(header=header, gesture=int(head.gesture)))
        self.bodies_pub.publish(IdsList(header=header, ids=list(bodies)))

    def _match(self, body: str, confidence: float) -> None:
        """The match between ``body`` and its face (the same digits): 1 associated, 0 no longer."""
        face = _ID_LETTER['head'] + body[1:]
        self.matches_pub.publish(
            IdsMatch(id1=face, id1_type=IdsMatch.FACE, id2=body, id2_type=IdsMatch.BODY, confidence=confidence)
        )

    def _keep_regions(self, names: list[str]) -> None:
        """Destroy the roi publisher of every face id not in ``names``."""
        for name in set(self.region_pubs) - set(names):
            self.node.destroy_publisher(self.region_pubs.pop(name))

    def _keep_bodies(self, bodies: list[str]) -> None:
        """Unmatch every body not in ``bodies`` from its face and destroy its gesture publisher."""
        for body in sorted(set(self.gesture_pubs) - set(bodies)):
            self._match(body, 0.0)
            self.node.destroy_publisher(self.gesture_pubs.pop(body))

    def clear(self, header: Any, settle: float = 0.0) -> None:
        """Nothing is tracked any more (the node is deactivated or shuts down): an empty ``tracked``
        list under ``header``, once, and every face's roi publisher destroyed. ``settle``: seconds
        to wait for every subscriber to acknowledge the list (a node about to destroy its
        publisher: unacknowledged, the list could die with it)."""
        self.frames_tracking.clear()
        self._keep_regions([])
        if self.bodies_pub is not None:
            self._keep_bodies([])
            self.bodies_pub.publish(IdsList(header=header))
        if self.tracked_pub is not None:
            self.tracked_pub.publish(IdsList(header=header))
            if settle > 0:
                self.tracked_pub.wait_for_all_acked(Duration(seconds=settle))
