"""What the tracker node publishes on each frame (:class:`TrackerOutputs`): the primary target's
metric pose and its covariance, its velocity and contour, every target on ``targets`` and on
the standard outputs (TF, REP-155, vision_msgs: :mod:`~human_tracker.ros.standard_outputs`), RViz
markers and the debug image (these two only while subscribed).

Poses are in the image's optical frame (metres): the target's distance from its scale and
physical width, or from a registered depth image where it has readings in the target's region
(:mod:`~human_tracker.vision.geometry.camera`, :mod:`~human_tracker.vision.geometry.depth`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from geometry_msgs.msg import (
    Point32,
    PolygonStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    TwistWithCovarianceStamped,
)
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import Image
from visualization_msgs.msg import MarkerArray

from human_tracker.drawing import annotate, draw_target
from human_tracker.ros.common import RESULT_QOS
from human_tracker.ros.image_conversion import array_to_image
from human_tracker.ros.markers import cleared_markers, target_markers
from human_tracker.ros.standard_outputs import PublishedTarget, StandardOutputs
from human_tracker.ros.tracker_parameters import TrackerSettings
from human_tracker.vision.filter.contour_filter import TrackEstimate, box_from_state
from human_tracker.vision.geometry.camera import metric_positions, position_covariance, undistort_pixels
from human_tracker.vision.geometry.depth import region_depth
from human_tracker.vision.people.gestures import Gesture, GestureReading
from human_tracker.vision.people.persons import TrackedTarget, targets_line
from human_tracker.vision.track.outcomes import state_words
from human_tracker.vision.track.target import TargetResult, TargetTracker

__all__ = [
    'UNKNOWN_VARIANCE',
    'estimate_values',
    'MetricPose',
    'PublishedFrame',
    'TrackerOutputs',
    'contour_message',
    'debug_view',
    'metric_pose',
    'velocity_message',
]

UNKNOWN_VARIANCE = 1e3
"""The variance of what is not observed (roll, pitch; a target's twist): large, to say so."""


class MetricPose(NamedTuple):
    """A target's pose in the optical frame and what it was computed with.

    Attributes:
        pose: The pose and its covariance (metres, radians).
        camera: (template, K, physical width, distortion) for
            :func:`~human_tracker.vision.geometry.camera.metric_positions`.
        distance: The depth image's distance (metres), None: from the scale.
        cloud: ``(P, 3)`` the particles' metric positions.
        depth_missing: A depth image was given but had no reading in the target's region.
    """

    pose: PoseWithCovariance
    camera: tuple[Any, ...]
    distance: float | None
    cloud: np.ndarray
    depth_missing: bool


def metric_pose(
    tracker: TargetTracker,
    estimate: TrackEstimate,
    shape: tuple[int, ...],
    lens: tuple[np.ndarray, np.ndarray | None],
    width: float,
    surface_to_centre: float,
    depth: np.ndarray | None,
    fit_residual_gain: float,
) -> MetricPose:
    """The metric pose of ``tracker``'s ``estimate`` (camera pixels of a frame of ``shape``, seen
    through ``lens``: K and distortion) of a target ``width`` metres across, ``surface_to_centre``
    metres deep, and its covariance: the particles' spread, the contour's own error
    (``fit_residual_gain`` position errors) and the depth readings' spread."""
    assert tracker.particles is not None
    k, distortion = lens
    measured = None
    if depth is not None:
        measured = region_depth(depth, box_from_state(estimate.state, tracker.template), shape[:2])
    distance, spread = (None, None) if measured is None else (measured[0] + surface_to_centre, measured[1])
    camera = (tracker.template, k, width, distortion)
    position = metric_positions(estimate.state, *camera, depth=distance)
    cloud = metric_positions(tracker.particles, *camera, depth=distance)
    pose = PoseWithCovariance()
    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (float(v) for v in position)
    theta = float(estimate.state[3])
    pose.pose.orientation.z = float(np.sin(theta / 2.0))
    pose.pose.orientation.w = float(np.cos(theta / 2.0))
    covariance = np.zeros((6, 6))
    reference_width = float(estimate.state[2]) * tracker.template.reference_box[2]  # pixels
    fit_share = fit_residual_gain * estimate.position_error / reference_width
    covariance[:3, :3] = position_covariance(cloud, position, fit_share, width, spread)
    covariance[3, 3] = covariance[4, 4] = UNKNOWN_VARIANCE
    covariance[5, 5] = estimate.covariance[3, 3]
    pose.covariance = covariance.reshape(-1).tolist()
    return MetricPose(pose, camera, distance, cloud, depth is not None and measured is None)


def estimate_values(result: TargetResult | None) -> dict[str, str]:
    """The estimate's shape, confidence and per-cue support, as ``status`` and ``/diagnostics``
    report them (empty without one)."""
    if result is None or result.estimate is None:
        return {}
    estimate = result.estimate
    facing = {} if result.facing is None else {'facing': str(result.facing)}
    return {
        'shape': estimate.shape,
        **facing,
        'confidence': f'{estimate.confidence:.3f}',
        'motion_support': f'{estimate.motion_support:.3f}',
        'skin_support': f'{estimate.skin_support:.3f}',
        'appearance_distance': f'{estimate.appearance_distance:.3f}',
        'effective_sample_size': f'{estimate.effective_sample_size:.1f}',
    }


def velocity_message(
    header: Any,
    cloud: np.ndarray,
    previous_cloud: np.ndarray,
    previous: np.ndarray,
    particles: np.ndarray,
    interval: float,
) -> TwistWithCovarianceStamped:
    """The AR(2) state's velocity: each particle's move since its state on the frame before
    (``(P, 3)`` metric positions, ``(P, 4)`` states), over ``interval`` s; the mean and the spread
    of the cloud's velocities."""
    linear = (cloud - previous_cloud) / interval
    turn = (particles[:, 3] - previous[:, 3]) / interval
    twist = TwistWithCovarianceStamped()
    twist.header = header
    twist.twist.twist.linear.x, twist.twist.twist.linear.y, twist.twist.twist.linear.z = (
        float(v) for v in linear.mean(axis=0)
    )
    twist.twist.twist.angular.z = float(turn.mean())
    covariance = np.zeros((6, 6))
    covariance[:3, :3] = np.cov(linear.T)
    covariance[3, 3] = covariance[4, 4] = UNKNOWN_VARIANCE
    covariance[5, 5] = float(turn.var())
    twist.twist.covariance = covariance.reshape(-1).tolist()
    return twist


def contour_message(header: Any, contour: np.ndarray) -> PolygonStamped:
    """The ``(N, 2)`` contour (pixels) as a polygon under ``header``."""
    message = PolygonStamped()
    message.header = header
    message.polygon.points = [Point32(x=float(x), y=float(y), z=0.0) for x, y in contour]
    return message


def debug_view(
    image: np.ndarray,
    outcomes: list[TrackedTarget],
    primary: TrackedTarget,
    particles: np.ndarray | None,
    mask: np.ndarray | None,
) -> np.ndarray:
    """The frame annotated: the ``primary`` target's contour, box, ``particles`` and cue
    support, the ``mask`` (motion, else skin), every face found, and the other followed targets
    in their ids' colours."""
    result = primary.result
    estimate = result.estimate
    label = (
        result.status
        if estimate is None
        else f'{state_words(result)} conf {estimate.confidence:.2f} motion {estimate.motion_support:.2f}'
        f' skin {estimate.skin_support:.2f} appearance {estimate.appearance_distance:.2f}'
    )
    if len(outcomes) > 1:
        label = f'{targets_line(outcomes)} | {primary.name}: {label}'
    view = annotate(
        image,
        contour=None if estimate is None else estimate.contour,
        box=None if estimate is None else estimate.box,
        particles=particles,
        label=label,
        motion=mask,
        detections=tuple(d for o in outcomes for d in o.result.detections),
    )
    for outcome in outcomes:
        other = outcome.result.estimate
        if outcome is not primary and other is not None and outcome.result.tracking:
            draw_target(view, outcome.id, f'{outcome.kind} {outcome.id}', other.contour, other.box)
    return view


@dataclass(frozen=True)
class PublishedFrame:
    """One tracked frame as :class:`TrackerOutputs` publishes it.

    Attributes:
        image: The camera's image (BGR).
        header: Its header: every message of the frame is stamped with it.
        outcomes: Every target's outcome on the frame.
        primary: The one ``pose``, ``velocity``, ``contour`` and ``markers`` follow.
        trackers: Each outcome's tracker, by the outcome's name (its particles, its template).
        lens: K and the distortion coefficients D the pixels are seen through.
        sizes: Each kind's physical width and the depth from its surface to its centre, metres.
        interval: Seconds since the frame before (0: the first, or after a gap).
        depth: The registered depth image (metres), or None.
        mask: The cue drawn on the debug image, or None.
        gestures: Each person's gesture by person number (people with a head and hands).
    """

    image: np.ndarray
    header: Any
    outcomes: list[TrackedTarget]
    primary: TrackedTarget
    trackers: Mapping[str, TargetTracker]
    lens: tuple[np.ndarray, np.ndarray | None]
    sizes: Mapping[str, tuple[float, float]]
    interval: float
    depth: np.ndarray | None
    mask: np.ndarray | None
    gestures: Mapping[int, GestureReading] = field(default_factory=dict)


class TrackerOutputs:
    """The tracker node's result publishers, and what they keep between frames.

    Attributes:
        last_distance: The depth image's distance of the primary target on the last frame
            published (metres), None: from the scale, or not published.
        frames_without_depth_reading: Frames whose depth image had no reading in the primary
            target's region.
    """

    def __init__(self, node: Node, settings: TrackerSettings) -> None:
        """Publishers on ``node``; what they publish as ``settings`` say."""
        self.kind = settings.kinds[0]
        self.fit_residual_gain = settings.fit_residual_gain
        self.pose_pub = node.create_publisher(PoseWithCovarianceStamped, 'pose', RESULT_QOS)
        self.velocity_pub = node.create_publisher(TwistWithCovarianceStamped, 'velocity', RESULT_QOS)
        self.contour_pub = node.create_publisher(PolygonStamped, 'contour', RESULT_QOS)
        self.debug_pub = node.create_publisher(Image, 'debug_image', RESULT_QOS)
        self.markers_pub = node.create_publisher(MarkerArray, 'markers', RESULT_QOS)
        self.targets_pub = node.create_publisher(Odometry, 'targets', RESULT_QOS) if len(settings.kinds) > 1 else None
        self.standard = StandardOutputs(
            node,
            tf=settings.publish_tf,
            faces=settings.publish_faces,
            frame_prefix=settings.frame_prefix,
            confirm_frames=settings.face_confirm_frames,
            bodies={'head', 'hand'} <= set(settings.kinds),
        )
        self.markers_shown = False
        self.last_distance: float | None = None
        self.frames_without_depth_reading = 0
        self._distance_of: TargetTracker | None = None  # the tracker ``last_distance`` was measured on

    def publish(self, frame: PublishedFrame) -> None:
        """Everything of one frame."""
        result = frame.primary.result
        tracker = frame.trackers[frame.primary.name]
        if tracker is not self._distance_of:
            # Another person's head: the last distance was the other's.
            self._distance_of, self.last_distance = tracker, None
        pose = self._publish_primary(frame, tracker) if result.tracking else None
        if pose is None:
            self.last_distance = None
        poses = self._target_poses(frame, pose)
        if self.targets_pub is not None:
            self._publish_targets(poses, frame.header)
        shape = frame.image.shape[:2]
        self.standard.publish(frame.header, shape, [self._published(frame, outcome, found) for outcome, found in poses])
        if self.markers_pub.get_subscription_count() > 0:
            self._publish_markers(frame, tracker)
        if self.debug_pub.get_subscription_count() > 0:
            view = debug_view(frame.image, frame.outcomes, frame.primary, tracker.particles, frame.mask)
            self.debug_pub.publish(array_to_image(view, 'bgr8', frame.header))

    def _metric_pose(
        self, frame: PublishedFrame, tracker: TargetTracker, estimate: TrackEstimate, kind: str
    ) -> MetricPose:
        """:func:`metric_pose` of a target of ``kind`` on ``frame``."""
        width, surface = frame.sizes[kind]
        shape = frame.image.shape[:2]
        return metric_pose(tracker, estimate, shape, frame.lens, width, surface, frame.depth, self.fit_residual_gain)

    def _publish_primary(self, frame: PublishedFrame, tracker: TargetTracker) -> PoseWithCovariance:
        """The pose and contour; the velocity too when the frame before is ``interval`` s back.
        With a ``depth`` image the distance is its readings' in the target's region. Returns the pose."""
        estimate = frame.primary.result.estimate
        particles, previous = tracker.particles, tracker.previous_particles
        assert estimate is not None and particles is not None and previous is not None
        found = self._metric_pose(frame, tracker, estimate, self.kind)
        self.frames_without_depth_reading += found.depth_missing
        self.pose_pub.publish(PoseWithCovarianceStamped(header=frame.header, pose=found.pose))
        # Distances of the same kind on both frames: measured on both, or both from the scale.
        distance = found.distance
        previous_distance, self.last_distance = self.last_distance, distance
        if frame.interval > 0:
            both = distance is not None and previous_distance is not None
            now = found.cloud if both or distance is None else metric_positions(particles, *found.camera)
            before = metric_positions(previous, *found.camera, depth=previous_distance if both else None)
            self.velocity_pub.publish(velocity_message(frame.header, now, before, previous, particles, frame.interval))
        self.contour_pub.publish(contour_message(frame.header, estimate.contour))
        return found.pose

    def _target_poses(
        self, frame: PublishedFrame, primary_pose: PoseWithCovariance | None
    ) -> list[tuple[TrackedTarget, PoseWithCovariance]]:
        """Each target TRACKING on this frame with its metric pose; the primary target's is the
        one ``pose`` got (``primary_pose``)."""
        poses = []
        for outcome in frame.outcomes:
            if not outcome.result.tracking:
                continue
            if outcome is frame.primary:
                assert primary_pose is not None  # published on pose: the primary target is TRACKING
                poses.append((outcome, primary_pose))
            else:
                tracker = frame.trackers[outcome.name]
                found = self._metric_pose(frame, tracker, outcome.result.estimate, outcome.kind)
                poses.append((outcome, found.pose))
        return poses

    def _publish_targets(self, poses: list[tuple[TrackedTarget, PoseWithCovariance]], header: Any) -> None:
        """One Odometry on ``targets`` per TRACKING target, named by its person, kind and id."""
        for outcome, pose in poses:
            odometry = Odometry(header=header, child_frame_id=f'person_{outcome.person}/{outcome.kind}_{outcome.id}')
            odometry.pose = pose
            odometry.twist.covariance = (np.eye(6) * UNKNOWN_VARIANCE).reshape(-1).tolist()
            self.targets_pub.publish(odometry)

    @staticmethod
    def _published(frame: PublishedFrame, outcome: TrackedTarget, pose: PoseWithCovariance) -> PublishedTarget:
        """A TRACKING target as the standard outputs take it: its box, pose and physical size."""
        estimate = outcome.result.estimate
        assert estimate is not None
        width, surface = frame.sizes[outcome.kind]
        box = tuple(float(v) for v in estimate.box)
        reading = frame.gestures.get(outcome.person) if outcome.kind == 'head' else None
        return PublishedTarget(
            id=outcome.id,
            kind=outcome.kind,
            box=box,
            confidence=float(estimate.confidence),
            pose=pose,
            theta=float(estimate.state[3]),
            facing=outcome.result.facing,
            size=(width, width * box[3] / box[2], 2.0 * surface),
            gesture=Gesture.NONE if reading is None else reading.gesture,
        )

    def _publish_markers(self, frame: PublishedFrame, tracker: TargetTracker) -> None:
        """The primary target's contour and label for RViz while the filter has an estimate;
        cleared once when it has none."""
        result, header = frame.primary.result, frame.header
        estimate = result.estimate
        if estimate is None:
            if self.markers_shown:
                self.markers_pub.publish(cleared_markers(header))
                self.markers_shown = False
            return
        k, distortion = frame.lens
        depth = self.last_distance  # this frame's measured distance, when it was published with one
        if depth is None or not result.tracking:
            depth = float(metric_positions(estimate.state, tracker.template, k, frame.sizes[self.kind][0])[2])
        contour = undistort_pixels(estimate.contour, k, distortion)
        facing = result.facing if result.tracking else None
        markers = target_markers(
            header, contour, depth, k, kind=self.kind, ident=0, status=result.status, facing=facing
        )
        self.markers_pub.publish(markers)
        self.markers_shown = True
