"""A node that records what a tracker publishes, keyed by image stamp (for demo and tests)."""

from __future__ import annotations

import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PolygonStamped, PoseWithCovarianceStamped, TransformStamped, TwistWithCovarianceStamped
from hri_msgs.msg import Gesture, IdsList, IdsMatch, NormalizedRegionOfInterest2D
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from tf2_msgs.msg import TFMessage
from vision_msgs.msg import Detection2DArray, Detection3DArray
from visualization_msgs.msg import MarkerArray

from human_tracker.io.images import stamp_ns

__all__ = ['PoseCollector']

_KEEP_ALL = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
# The tracker's status is latched: a late subscriber still gets the current state.
_LATCHED = QoSProfile(
    depth=1000,
    reliability=ReliabilityPolicy.RELIABLE,
    history=HistoryPolicy.KEEP_LAST,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


class PoseCollector(Node):
    """Subscribes ``pose``, ``velocity``, ``contour`` and ``targets`` (reliable, deep queue) and
    stores them by stamp (``targets``: every target's message of that stamp).

    It also keeps the latest ``/diagnostics`` values of every node, by status name, every
    ``status`` message in order (its state and values), and with ``markers`` the ``markers``
    arrays by stamp (a subscriber makes the tracker publish them).

    With ``standard`` it reads the standard outputs as their own consumers do: ``/tf``,
    ``detections`` and ``detections_3d`` by stamp, and REP-155's faces as a ROS4HRI client: every
    ``/humans/faces/tracked`` list in order, and each listed id's ``roi`` subscribed when the id
    appears and unsubscribed when it leaves; the same of ``/humans/bodies/tracked`` and each
    body's ``gesture``, and every ``/humans/candidate_matches`` message in order.
    """

    def __init__(self, namespace: str = '', *, markers: bool = False, standard: bool = False) -> None:
        super().__init__('pose_collector', namespace=namespace)
        self.poses: dict[int, PoseWithCovarianceStamped] = {}
        self.pose_arrivals: dict[int, float] = {}  # monotonic seconds each pose arrived, by stamp
        self.contours: dict[int, np.ndarray] = {}
        self.frame_ids: set[str] = set()
        self.diagnostics: dict[str, dict[str, str]] = {}
        self.create_subscription(PoseWithCovarianceStamped, 'pose', self._on_pose, _KEEP_ALL)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, _KEEP_ALL)
        self.create_subscription(PolygonStamped, 'contour', self._on_contour, _KEEP_ALL)
        self.velocities: dict[int, TwistWithCovarianceStamped] = {}
        self.create_subscription(TwistWithCovarianceStamped, 'velocity', self._on_velocity, _KEEP_ALL)
        self.statuses: list[dict[str, str]] = []
        self.create_subscription(DiagnosticArray, 'status', self._on_status, _LATCHED)
        self.targets: dict[int, list[Odometry]] = {}
        self.create_subscription(Odometry, 'targets', self._on_target, _KEEP_ALL)
        self.markers: dict[int, MarkerArray] = {}
        if markers:
            self.create_subscription(MarkerArray, 'markers', self._on_markers, _KEEP_ALL)
        self.transforms: dict[int, list[TransformStamped]] = {}
        self.detections: dict[int, Detection2DArray] = {}
        self.detections_3d: dict[int, Detection3DArray] = {}
        self.tracked: list[IdsList] = []
        self.regions: dict[str, dict[int, NormalizedRegionOfInterest2D]] = {}
        self._region_subscriptions: dict[str, object] = {}
        self.bodies: list[IdsList] = []
        self.gestures: dict[str, dict[int, Gesture]] = {}
        self._gesture_subscriptions: dict[str, object] = {}
        self.matches: list[IdsMatch] = []
        if standard:
            self.create_subscription(TFMessage, '/tf', self._on_tf, _KEEP_ALL)
            self.create_subscription(Detection2DArray, 'detections', self._keep(self.detections), _KEEP_ALL)
            self.create_subscription(Detection3DArray, 'detections_3d', self._keep(self.detections_3d), _KEEP_ALL)
            self.create_subscription(IdsList, '/humans/faces/tracked', self._on_tracked, _LATCHED)
            self.create_subscription(IdsList, '/humans/bodies/tracked', self._on_bodies, _LATCHED)
            self.create_subscription(IdsMatch, '/humans/candidate_matches', self.matches.append, _KEEP_ALL)

    def received(self) -> int:
        """How many messages of a frame's outputs have been stored so far (they grow as they arrive)."""
        by_stamp = (self.poses, self.contours, self.velocities, self.markers, self.detections, self.detections_3d)
        lists = (*self.targets.values(), *self.transforms.values(), self.tracked, self.bodies, self.matches)
        by_id = (*self.regions.values(), *self.gestures.values())
        return sum(map(len, (*by_stamp, *lists, *by_id)))

    @staticmethod
    def _keep(store: dict) -> object:
        return lambda msg: store.__setitem__(stamp_ns(msg.header), msg)

    def _on_tf(self, msg: TFMessage) -> None:
        for transform in msg.transforms:
            self.transforms.setdefault(stamp_ns(transform.header), []).append(transform)

    def _on_tracked(self, msg: IdsList) -> None:
        self.tracked.append(msg)
        self._follow(
            msg.ids, self._region_subscriptions, self.regions, '/humans/faces/{}/roi', NormalizedRegionOfInterest2D
        )

    def _on_bodies(self, msg: IdsList) -> None:
        self.bodies.append(msg)
        self._follow(msg.ids, self._gesture_subscriptions, self.gestures, '/humans/bodies/{}/gesture', Gesture)

    def _follow(self, ids: list[str], subscriptions: dict, stores: dict, topic: str, kind: type) -> None:
        """Subscribe each id's ``topic`` (stored by stamp in ``stores[id]``) when it is listed,
        and unsubscribe it when it leaves the list."""
        for ident in set(subscriptions) - set(ids):
            self.destroy_subscription(subscriptions.pop(ident))
        for ident in ids:
            if ident not in subscriptions:
                keep = self._keep(stores.setdefault(ident, {}))
                subscriptions[ident] = self.create_subscription(kind, topic.format(ident), keep, _LATCHED)

    def _on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        self.poses[stamp_ns(msg.header)] = msg
        self.pose_arrivals[stamp_ns(msg.header)] = time.monotonic()
        self.frame_ids.add(msg.header.frame_id)

    def _on_target(self, msg: Odometry) -> None:
        self.targets.setdefault(stamp_ns(msg.header), []).append(msg)

    def _on_velocity(self, msg: TwistWithCovarianceStamped) -> None:
        self.velocities[stamp_ns(msg.header)] = msg

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            self.diagnostics[status.name] = {kv.key: kv.value for kv in status.values}

    def _on_status(self, msg: DiagnosticArray) -> None:
        self.statuses.append({kv.key: kv.value for kv in msg.status[0].values})

    def states(self) -> list[str]:
        """The tracker's states in the order received, each repeat of one state dropped."""
        states = [status['state'] for status in self.statuses]
        return [state for k, state in enumerate(states) if k == 0 or state != states[k - 1]]

    def spin_until_diagnostics(self, executor: SingleThreadedExecutor, name: str, timeout: float) -> dict[str, str]:
        """Spin until a /diagnostics status named ``name`` arrives after this call; return its values."""
        self.diagnostics.pop(name, None)
        deadline = time.monotonic() + timeout
        while name not in self.diagnostics and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        return self.diagnostics.get(name, {})

    def _on_markers(self, msg: MarkerArray) -> None:
        if msg.markers:
            self.markers[stamp_ns(msg.markers[0].header)] = msg

    def _on_contour(self, msg: PolygonStamped) -> None:
        self.contours[stamp_ns(msg.header)] = np.array([[p.x, p.y] for p in msg.polygon.points], dtype=np.float64)

    def wait_for_publisher(self, executor: SingleThreadedExecutor, timeout: float) -> bool:
        """Spin until a node publishes ``pose`` (so no early pose is missed)."""
        deadline = time.monotonic() + timeout
        topic = self.resolve_topic_name('pose')
        while time.monotonic() < deadline:
            if self.count_publishers(topic) > 0:
                return True
            executor.spin_once(timeout_sec=0.05)
        return False
