"""``tracker_node``: the particle-filter contour tracker as a ROS 2 node.

Subscribes ``image`` (or ``image/compressed``) and ``camera_info``; publishes ``pose``
(PoseWithCovarianceStamped, metres, optical frame), ``contour`` (PolygonStamped, pixels),
``debug_image`` (only when subscribed) and ``/diagnostics``. Every output copies the
header of the image it was computed from.
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np
import rclpy
import rclpy.logging
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Point32, PolygonStamped, PoseWithCovarianceStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

from human_tracker.drawing import annotate
from human_tracker.ros.common import (
    RESULT_QOS,
    FrameCounters,
    StageTimer,
    declare,
    diagnostic_status,
    image_qos,
    publish_diagnostics,
)
from human_tracker.ros.image_conversion import ImageConversionError, array_to_image, message_to_bgr8, to_mono8
from human_tracker.vision.camera import default_camera_matrix, metric_positions
from human_tracker.vision.measurement import edge_map
from human_tracker.vision.templates import make_template
from human_tracker.vision.tracker import ContourTracker, TrackerParameters, TrackEstimate

__all__ = ['TrackerNode', 'main']

# Parameters that map one to one onto TrackerParameters and may change at run time.
_GAINS = (
    'num_particles',
    'search_halfwidth',
    'miss_penalty',
    'likelihood_gain',
    'orientation_tolerance',
    'velocity_damping',
    'process_noise',
)
_UNKNOWN_VARIANCE = 1e3  # roll and pitch are not observed: a large variance says so


def _stamp_ns(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


class TrackerNode(Node):
    """Tracks a head (or hand) silhouette in the image stream and publishes its pose."""

    def __init__(self, *, subscribe_image: bool = True, **kwargs: Any) -> None:
        super().__init__('tracker_node', **kwargs)
        defaults = TrackerParameters()
        target = declare(self, 'target', 'head', 'What to track: head (head-and-shoulders template).', read_only=True)
        template_file = declare(
            self,
            'template_file',
            '',
            'JSON template file replacing the built-in one (empty: built-in).',
            read_only=True,
        )
        num_points = declare(
            self, 'num_points', 48, 'N, measurement points along the spline (§2.3).', low=4, high=1024, read_only=True
        )
        self.template = make_template(target, num_points, template_file)
        params = TrackerParameters(
            num_particles=declare(
                self, 'num_particles', defaults.num_particles, 'P, number of particles.', low=1, high=100000
            ),
            search_halfwidth=declare(
                self,
                'search_halfwidth',
                defaults.search_halfwidth,
                'δ (eq. 2): pixels searched each side of a point along its normal.',
                low=0.5,
                high=500.0,
            ),
            miss_penalty=declare(
                self,
                'miss_penalty',
                defaults.miss_penalty,
                'ρ (eqs. 2-3): cost of a point with no edge within δ.',
                low=0.0,
                high=1e9,
            ),
            likelihood_gain=declare(
                self,
                'likelihood_gain',
                defaults.likelihood_gain,
                'K (eq. 1): gain of the likelihood exp(-K Σ φ).',
                low=1e-9,
                high=1e3,
            ),
            orientation_tolerance=declare(
                self,
                'orientation_tolerance',
                defaults.orientation_tolerance,
                'Largest angle (rad) between an edge gradient and the contour normal for the edge to count; '
                'π/2 accepts every edge (the paper).',
                low=0.01,
                high=float(np.pi / 2),
            ),
            velocity_damping=declare(
                self,
                'velocity_damping',
                defaults.velocity_damping,
                'a of the AR(2) dynamics (§2.2): 0 random walk, 1 constant velocity.',
                low=0.0,
                high=1.0,
            ),
            process_noise=tuple(
                declare(
                    self,
                    'process_noise',
                    list(defaults.process_noise),
                    'W (§2.2): std of x, y (px), s (fraction), θ (rad) per frame.',
                )
            ),
            initial_spread=tuple(
                declare(
                    self,
                    'initial_spread',
                    list(defaults.initial_spread),
                    'Σ (§2.5): std of the initial cloud, x, y (px), s (fraction), θ (rad).',
                    read_only=True,
                )
            ),
            seed=declare(
                self,
                'seed',
                0,
                'Seed of the particle filter (replays are reproducible).',
                low=0,
                high=2**31 - 1,
                read_only=True,
            ),
        )
        self.tracker = ContourTracker(self.template, params)
        self.init_box = [
            float(v)
            for v in declare(
                self,
                'init_box',
                [0.0, 0.0, 0.0, 0.0],
                'Initial box x, y, w, h (pixels) of the head or hand in the first frame; zeros: none.',
                read_only=True,
            )
        ]
        if len(self.init_box) != 4:
            raise ValueError(f'init_box must be [x, y, w, h], got {self.init_box}')
        self.edge_blur = declare(
            self, 'edge_blur_sigma', 1.5, 'Gaussian pre-filter of the edge detector, pixels.', low=0.0, high=20.0
        )
        self.canny_low = declare(self, 'canny_low', 40.0, 'Canny low hysteresis threshold.', low=0.0, high=10000.0)
        self.canny_high = declare(self, 'canny_high', 100.0, 'Canny high hysteresis threshold.', low=0.0, high=10000.0)
        self.target_width = declare(
            self,
            'target_width',
            0.16,
            'Physical width of the head (or hand) in metres, for depth from scale.',
            low=0.01,
            high=2.0,
        )
        transport = declare(
            self, 'image_transport', 'raw', 'Image input: raw (image) or compressed (image/compressed).', read_only=True
        )
        if transport not in ('raw', 'compressed'):
            raise ValueError(f"image_transport must be 'raw' or 'compressed', got {transport!r}")
        period = declare(
            self,
            'diagnostics_period',
            1.0,
            'Seconds between /diagnostics messages.',
            low=0.05,
            high=60.0,
            read_only=True,
        )
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self.counters = FrameCounters()
        self.timer_stats = StageTimer()
        self.camera_matrix: np.ndarray | None = None
        self.last_stamp_ns = -1
        self.last_estimate: TrackEstimate | None = None

        self.pose_pub = self.create_publisher(PoseWithCovarianceStamped, 'pose', RESULT_QOS)
        self.contour_pub = self.create_publisher(PolygonStamped, 'contour', RESULT_QOS)
        self.debug_pub = self.create_publisher(Image, 'debug_image', RESULT_QOS)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', RESULT_QOS)
        self.create_subscription(CameraInfo, 'camera_info', self._on_camera_info, RESULT_QOS)
        if subscribe_image:
            qos = image_qos(self)
            if transport == 'compressed':
                self.create_subscription(CompressedImage, 'image/compressed', self.on_image, qos)
            else:
                self.create_subscription(Image, 'image', self.on_image, qos)
        self.create_timer(period, self._publish_diagnostics)
        self._warm_up()
        self.get_logger().info(
            f'ready: tracking {target} with {params.num_particles} particles, {self.template.num_points} points'
        )

    def _warm_up(self) -> None:
        """Run the compiled kernels once so the first real frame is not slowed by JIT."""
        probe = ContourTracker(self.template, TrackerParameters(num_particles=2))
        probe.initialise(np.array([16.0, 16.0, 8.0, 0.0]))
        probe.step(np.zeros((32, 32), dtype=np.uint8))

    @property
    def state(self) -> str:
        """Tracking state for diagnostics: WAITING (no initial box yet) or TRACKING."""
        return 'TRACKING' if self.tracker.initialised else 'WAITING'

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        """Apply tracker gains at run time after checking them all together."""
        changes = {p.name: p.value for p in parameters if p.name in _GAINS}
        if not changes:
            return SetParametersResult(successful=True)
        current = self.tracker.parameters
        candidate = TrackerParameters(
            **{**current.__dict__, **{k: tuple(v) if k == 'process_noise' else v for k, v in changes.items()}}
        )
        try:
            candidate.validate()
        except ValueError as err:
            return SetParametersResult(successful=False, reason=str(err))
        self.tracker.parameters = candidate
        self.get_logger().info(f'tracker gains changed: {changes}')
        return SetParametersResult(successful=True)

    def _on_camera_info(self, msg: CameraInfo) -> None:
        k = np.asarray(msg.k, dtype=np.float64).reshape(3, 3)
        if k[0, 0] > 0 and k[1, 1] > 0:
            self.camera_matrix = k

    def on_image(self, msg: Image | CompressedImage) -> None:
        """Convert one image message and track on it; bad frames are counted, never fatal."""
        self.counters.received += 1
        self.timer_stats.arrived()
        try:
            image = message_to_bgr8(msg)
        except ImageConversionError as err:
            self.counters.reject('conversion')
            self.get_logger().warn(f'frame rejected: {err}', throttle_duration_sec=5.0)
            return
        self.handle_frame(image, msg.header)

    def handle_frame(self, image: np.ndarray, header: Any) -> TrackEstimate | None:
        """Track on one BGR frame and publish the results under ``header``."""
        stamp = _stamp_ns(header)
        if stamp <= self.last_stamp_ns:
            self.counters.skipped += 1
            self.get_logger().warn('frame skipped: stamp not newer than the last one', throttle_duration_sec=5.0)
            return None
        self.last_stamp_ns = stamp
        start = time.perf_counter()
        edges = edge_map(
            to_mono8(image), blur_sigma=self.edge_blur, low_threshold=self.canny_low, high_threshold=self.canny_high
        )
        if not self.tracker.initialised:
            if self.init_box[2] <= 0 or self.init_box[3] <= 0:
                self.counters.processed += 1
                return None
            self.tracker.initialise_from_box(tuple(self.init_box))
        estimate = self.tracker.step(edges)
        self.last_estimate = estimate
        self.counters.processed += 1
        self._publish(estimate, header, image.shape)
        self.timer_stats.took(time.perf_counter() - start)
        if self.debug_pub.get_subscription_count() > 0:
            label = f'{self.state} conf {estimate.confidence:.2f}'
            debug = annotate(
                image, contour=estimate.contour, box=estimate.box, particles=self.tracker.particles, label=label
            )
            self.debug_pub.publish(array_to_image(debug, 'bgr8', header))
        return estimate

    def _publish(self, estimate: TrackEstimate, header: Any, shape: tuple[int, ...]) -> None:
        k = self.camera_matrix if self.camera_matrix is not None else default_camera_matrix(shape[1], shape[0])
        position = metric_positions(estimate.state, self.template, k, self.target_width)
        assert self.tracker.particles is not None
        cloud = metric_positions(self.tracker.particles, self.template, k, self.target_width)
        pose = PoseWithCovarianceStamped()
        pose.header = header
        pose.pose.pose.position.x, pose.pose.pose.position.y, pose.pose.pose.position.z = (float(v) for v in position)
        theta = float(estimate.state[3])
        pose.pose.pose.orientation.z = float(np.sin(theta / 2.0))
        pose.pose.pose.orientation.w = float(np.cos(theta / 2.0))
        covariance = np.zeros((6, 6))
        covariance[:3, :3] = np.cov(cloud.T)
        covariance[3, 3] = covariance[4, 4] = _UNKNOWN_VARIANCE
        covariance[5, 5] = estimate.covariance[3, 3]
        pose.pose.covariance = covariance.reshape(-1).tolist()
        self.pose_pub.publish(pose)
        contour = PolygonStamped()
        contour.header = header
        contour.polygon.points = [Point32(x=float(x), y=float(y), z=0.0) for x, y in estimate.contour]
        self.contour_pub.publish(contour)

    def _publish_diagnostics(self) -> None:
        extra: dict[str, Any] = {'particles': self.tracker.parameters.num_particles}
        if self.last_estimate is not None:
            extra['confidence'] = f'{self.last_estimate.confidence:.3f}'
            extra['effective_sample_size'] = f'{self.last_estimate.effective_sample_size:.1f}'
        status = diagnostic_status(self, self.counters, self.timer_stats, state=self.state, extra=extra)
        publish_diagnostics(self, self.diagnostics_pub, [status])


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker tracker_node``; returns the exit code."""
    rclpy.init(args=args)
    node = None
    code = 0
    try:
        node = TrackerNode()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ValueError as err:
        # A parameter out of its range or of the wrong kind: refuse to start, say why.
        rclpy.logging.get_logger('tracker_node').error(f'cannot start: {err}')
        code = 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())
