"""``tracker_node``: the particle-filter contour tracker as a ROS 2 node.

Subscribes ``image`` (or ``image/compressed``), ``camera_info`` and, with
``motion_input: foreground`` or ``motion``, that mask topic, and with ``skin_input: true``
the ``skin`` labels, each matched to the image by exact stamp. Publishes ``pose``
(PoseWithCovarianceStamped, metres, optical frame), ``velocity`` (TwistWithCovarianceStamped,
m/s and rad/s, optical frame) and ``contour`` (PolygonStamped, pixels) while the target is
tracked, ``status`` (DiagnosticArray, latched: WAITING / TRACKING /
LOST with the confidence and each cue's support, on every change and every
``status_period``), ``markers`` (MarkerArray for RViz: the contour at the target's depth and
a label, while the filter has an estimate) and ``debug_image`` (each only when subscribed),
and ``/diagnostics``. Every output copies the header of the image it was computed from.

A box on ``init_roi`` (sensor_msgs/RegionOfInterest, image pixels) starts the filter there on
the next frame; the service ``~/reset`` (std_srvs/Trigger) forgets the target: WAITING for
motion or a box.

With ``target: person`` it follows a head and ``hands`` hands of up to ``max_people`` people
(:mod:`~human_tracker.vision.people`): the topics above are the primary target's, on each
frame the head ``primary_id`` names while it is followed, else the followed head nearest the
image's centre (:func:`~human_tracker.vision.people.primary_target`), and
``targets`` (nav_msgs/Odometry, one message per tracked target per frame) gives every target:
``child_frame_id`` ``person_<person>/<kind>_<id>``, the pose and its covariance in the image's
optical frame (``header``); the twist is not estimated per target (unknown covariance).
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections import OrderedDict, deque
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import (
    Point32,
    PolygonStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    TwistWithCovarianceStamped,
)
from nav_msgs.msg import Odometry
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image, RegionOfInterest
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from human_tracker.drawing import annotate, draw_target
from human_tracker.ros.common import LATCHED_QOS, RESULT_QOS, WORKING_WIDTH_DESCRIPTION, declare, node_status
from human_tracker.ros.image_conversion import ImageConversionError, array_to_image, image_to_array
from human_tracker.ros.markers import cleared_markers, target_markers
from human_tracker.ros.stage import DEFERRED, ImageStage, ParameterSpec, spin_node, stamp_ns
from human_tracker.vision.camera import FIT_RESIDUAL_GAIN, metric_positions, position_covariance, undistort_pixels
from human_tracker.vision.depth import depth_image_to_metres, region_depth
from human_tracker.vision.lifecycle import LOST
from human_tracker.vision.people import PersonTracker, TrackedTarget, kinds_of, primary_target, targets_line
from human_tracker.vision.resolution import same_frame
from human_tracker.vision.skin import has_colour
from human_tracker.vision.target import TargetParameters, TargetResult, TargetTracker, parameters_for
from human_tracker.vision.templates import make_template
from human_tracker.vision.tracker import TrackerParameters, TrackEstimate, box_from_state, check_box_in_image

__all__ = ['FILTER_PARAMETERS', 'TARGET_PARAMETERS', 'TrackerNode', 'main']

FILTER_PARAMETERS = (
    ParameterSpec('num_particles', 'P, number of particles.', 1, 100000),
    ParameterSpec(
        'search_halfwidth', 'δ (eq. 2): pixels searched each side of a contour point along its normal.', 0.5, 500.0
    ),
    ParameterSpec('miss_penalty', 'ρ (eqs. 2-3): cost of a point with no edge within δ.', 0.0, 1e9),
    ParameterSpec('likelihood_gain', 'K (eq. 1): gain of the likelihood exp(-K Σ φ).', 1e-9, 1e3),
    ParameterSpec(
        'orientation_tolerance',
        'Largest angle (rad) between an edge gradient and the contour normal for the edge to count; '
        'π/2: every edge (the paper).',
        0.01,
        float(np.pi / 2),
    ),
    ParameterSpec('velocity_damping', 'a of the AR(2) dynamics (§2.2): 0 random walk, 1 constant velocity.', 0.0, 1.0),
    ParameterSpec('process_noise', 'W (§2.2): std of x, y (px), s (fraction), θ (rad) per frame.'),
    ParameterSpec('initial_spread', 'Σ (§2.5): std of the initial cloud: x, y (px), s (fraction), θ (rad).'),
    ParameterSpec(
        'interior_weight', 'w (§3.2, > 1): non-skin inside the contour costs 1/w of skin outside.', 1.0001, 1e6
    ),
    ParameterSpec('colour_depth', 'How far inside / outside the contour skin is sampled, template units.', 0.001, 1.0),
    ParameterSpec('appearance_gain', 'λ of the appearance term exp(-λ D²) of the fused likelihood.', 0.0, 1e4),
    ParameterSpec('importance_share', 'Share of particles drawn around detections with the f/g correction.', 0.0, 1.0),
    ParameterSpec('restart_share', 'Share of particles drawn around detections without correction.', 0.0, 1.0),
    ParameterSpec('proposal_spread', 'Std of particles drawn around a detection: x, y (px), s (fraction), θ (rad).'),
    ParameterSpec(
        'detection_floor', 'Likelihood of a state far from every face found, relative to one on a face.', 1e-9, 1.0
    ),
    ParameterSpec(
        'shape_switch', "Probability a frame that a particle changes to another of the template's shapes.", 0.0, 1.0
    ),
    ParameterSpec('variant_penalty', "Cost of a particle in a variant shape (a closed hand), in ρ's.", 0.0, 1e3),
    ParameterSpec('min_scale', 'Smallest scale s: reference region width in pixels.', 1.0, 1e5),
    ParameterSpec('max_scale', 'Largest scale s: reference region width in pixels.', 1.0, 1e5),
    ParameterSpec('seed', 'Seed of the particle filter (replays are reproducible).', 0, 2**31 - 1, runtime=False),
)

TARGET_PARAMETERS = (
    ParameterSpec('likelihood', 'fused (shape of eqs. 1-4 times colour appearance) or paper (shape only).'),
    ParameterSpec('appearance_parts', 'Horizontal bands of the target region with their own histogram.', 1, 16),
    ParameterSpec('adaptation_rate', 'How fast the appearance reference follows a confident track.', 0.0, 1.0),
    ParameterSpec(
        'lost_appearance_distance',
        'Bhattacharyya distance from the reference above which a frame is weak.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'proposals',
        'faces (face detections draw particles, start and restart; needs dlib), skin (skin regions draw'
        ' particles: a hand) or off.',
        runtime=False,
    ),
    ParameterSpec('avoid_faces', 'A hand: a contour on a detected face is weak; no hypothesis there.', runtime=False),
    ParameterSpec('detect_every', 'Run the face detector on every this many frames.', 1, 100000),
    ParameterSpec('patient_every', 'Frames between face detector runs once several found no face.', 1, 100000),
    ParameterSpec('face_search_reach', 'Face sizes around the predicted face the detector looks within.', 0.5, 10.0),
    ParameterSpec('detector_thread', 'Face detector in its own thread; its faces serve the next frame.', runtime=False),
    ParameterSpec(
        'detector_wait_interval',
        'Seconds between frames above which a frame waits for its own face detector run (a slow camera).',
        0.0,
        3600.0,
    ),
    ParameterSpec(
        'compensate_camera', "Carry the particles with the camera's shake (as the background stage measures it)."
    ),
    ParameterSpec('estimate_camera_motion', "Without a background stage in process, measure the camera's motion here."),
    ParameterSpec('pan_smoothing', "Weight of the past in the camera's mean shift, left to the dynamics.", 0.0, 0.99),
    ParameterSpec(
        'motion_mode',
        'How motion enters the likelihood: off (eqs. 1-2), weighted (eqs. 3-4) or mask (moving edges only).',
    ),
    ParameterSpec(
        'colour_mode',
        'How skin enters: off, weighted (colour term γ of §3.2) or mask (edges near skin regions only).',
    ),
    ParameterSpec(
        'max_motion_fraction',
        'A motion mask over more of the frame than this is set aside (camera moved, light changed); 1: keep all.',
        0.01,
        1.0,
    ),
    ParameterSpec('skin_margin', 'Dilation (pixels) of skin regions in the mask colour mode.', 0, 100),
    ParameterSpec('init_region', 'Region X_0 comes from: motion or skin.'),
    ParameterSpec('init_method', 'Initialisation from the moving region: scan (§2.5.2, head) or moments (§2.5.1).'),
    ParameterSpec('upper_end_restarts', 'With moments, once started, X_0 of an elongated region at its upper end.'),
    ParameterSpec('upright_angle', 'θ_upright of the scan initialisation, rad.', -3.2, 3.2),
    ParameterSpec('min_blob_area', 'Smallest moving region (pixels) that can start or restart a track.', 1, 10_000_000),
    ParameterSpec(
        'region_closing', 'Closing radius (pixels) joining a moving silhouette before it is measured.', 0, 100
    ),
    ParameterSpec(
        'init_confidence',
        'Fraction of contour points on edges a motion hypothesis needs to start the filter.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'switch_margin',
        'How much more moving support a hypothesis elsewhere needs to restart the filter there.',
        0.0,
        1.0,
    ),
    ParameterSpec('hypothesis_samples', 'States scored around a motion hypothesis.', 1, 100000),
    ParameterSpec('hypothesis_blobs', 'With moments, how many of the largest regions give an X_0.', 1, 100),
    ParameterSpec('lost_confidence', 'Fraction of contour points on edges below which a frame is weak.', 0.0, 1.0),
    ParameterSpec(
        'lost_motion_support',
        'Fraction of contour points on the motion mask below which a frame is weak; 0: off.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'init_motion_support',
        'With a motion mask, fraction of contour points on it a hypothesis needs to start the filter.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'lost_skin_support',
        'Share of the contour interior on skin below which a frame with skin labels is weak; 0: off.',
        0.0,
        1.0,
    ),
    ParameterSpec('lost_frames', 'Consecutive weak frames after which the target is lost.', 1, 100000),
    ParameterSpec('colour_edges', 'Detect edges on the colour image (strongest channel), not on its intensity.'),
    ParameterSpec('edge_blur_sigma', 'Gaussian pre-filter of the edge detector, pixels.', 0.0, 20.0),
    ParameterSpec('canny_low', 'Canny low hysteresis threshold.', 0.0, 10000.0),
    ParameterSpec('canny_high', 'Canny high hysteresis threshold.', 0.0, 10000.0),
    ParameterSpec('working_width', WORKING_WIDTH_DESCRIPTION, 0, 100000, runtime=False),
    ParameterSpec(
        'min_target_width',
        'Working pixels a target must span: a smaller one is tracked on a less reduced frame; 0: off.',
        0.0,
        10000.0,
    ),
)
_UNKNOWN_VARIANCE = 1e3  # roll and pitch are not observed: a large variance says so
_MOTION_INPUTS = ('none', 'foreground', 'motion')
_REMEMBERED_STAMPS = 1000  # frames whose arrival is remembered (33 s at 30 Hz)
# Typical adult widths of the reference regions, metres: head (ear to ear) and open hand.
_TARGET_WIDTHS = {'head': 0.16, 'hand': 0.18}
# How far behind its visible surface the target's centre lies, metres: a head is about 0.2 m
# deep and the middle of the face about 8 cm in front of its centre; a hand is flat.
_SURFACE_TO_CENTRE = {'head': 0.08, 'hand': 0.01}


GREY_INPUT_TEXT = 'the image has no colour (a grey-level camera?): no skin can be found, so no hand is followed'


class TrackerNode(ImageStage):
    """Tracks a head (or hand) silhouette in the image stream and publishes its pose."""

    def __init__(self, *, subscribe_image: bool = True, **kwargs: Any) -> None:
        super().__init__('tracker_node', subscribe_image=subscribe_image, **kwargs)
        target = declare(
            self,
            'target',
            'head',
            'What to track: head (head-and-shoulders), hand (open or closed) or person (a head and hands, each with '
            'its id on targets).',
            read_only=True,
        )
        hands = declare(
            self, 'hands', 1, "With target person: a person's hands followed.", low=0, high=2, read_only=True
        )
        max_people = declare(
            self,
            'max_people',
            1,
            'With target person: the most people followed at once.',
            low=1,
            high=10,
            read_only=True,
        )
        # Read on every frame: a behaviour names the person it talks to once it has seen their id.
        declare(
            self,
            'primary_id',
            0,
            'With target person: the id of the head pose, contour and status follow while it is followed; 0 (or '
            "the id not followed): the head nearest the image's centre.",
            low=0,
            high=2**31 - 1,
        )
        id_hold_frames = declare(
            self,
            'id_hold_frames',
            15,
            "With target person: frames a LOST target's id is held; taken up again near where it was, it gets it back.",
            low=0,
            high=1000,
            read_only=True,
        )
        kinds = kinds_of(target, hands)
        template_file = declare(
            self,
            'template_file',
            '',
            'JSON template, or open_hand, closed_hand, head_and_shoulders, for the built-in one (empty: built-in).',
            read_only=True,
        )
        num_points = declare(
            self, 'num_points', 48, 'N, measurement points along the spline (§2.3).', low=4, high=1024, read_only=True
        )
        # The primary target (the head of a person) is the one of pose, contour, status and markers.
        self.kind = kinds[0]
        self.kinds = kinds
        filter_parameters = self.bind_parameters(TrackerParameters(), FILTER_PARAMETERS, self._apply_filter)
        target_parameters = self.bind_parameters(parameters_for(self.kind), TARGET_PARAMETERS, self._apply_target)
        box = [
            float(v)
            for v in declare(
                self,
                'init_box',
                [0.0, 0.0, 0.0, 0.0],
                'Box x, y, w, h (pixels) of the target in the first frame; zeros: start from motion.',
                read_only=True,
            )
        ]
        if len(box) != 4 or min(box[2:]) < 0:
            raise ValueError(f'init_box must be [x, y, w >= 0, h >= 0], got {box}')
        self.init_box = tuple(box) if box[2] > 0 and box[3] > 0 else None
        self.target_width = declare(
            self,
            'target_width',
            _TARGET_WIDTHS[self.kind],
            'Physical width of the head (or hand), metres: depth from scale (a person: the head; its hand '
            f'{_TARGET_WIDTHS["hand"]}).',
            low=0.01,
            high=2.0,
        )
        self.motion_input = declare(
            self,
            'motion_input',
            'none',
            'Motion cue topic: none, foreground (background_node) or motion (optical_flow_node).',
            read_only=True,
        )
        if self.motion_input not in _MOTION_INPUTS:
            raise ValueError(f'motion_input must be one of {", ".join(_MOTION_INPUTS)}, got {self.motion_input!r}')
        skin_input = declare(
            self, 'skin_input', False, 'Subscribe the skin labels of skin_node (§3.2).', read_only=True
        )
        self.match_timeout = declare(
            self,
            'match_timeout',
            0.25,
            'Seconds a frame waits for its masks (motion, skin) before it is tracked without.',
            low=0.0,
            high=10.0,
        )
        self.fit_residual_gain = declare(
            self,
            'fit_residual_gain',
            FIT_RESIDUAL_GAIN,
            "The contour's own error in the pose's covariance, in its position errors (the RMS "
            'distance from its points to the edges they found, above that of a contour on the '
            'outline): across the optical axis, and the same share of the distance along the ray.',
            low=0.0,
            high=100.0,
            read_only=True,
        )
        self.image_rectified = declare(
            self,
            'image_rectified',
            False,
            'The image is rectified (image_rect): rays through camera_info P, no distortion; '
            'false: through K after undistorting with D.',
            read_only=True,
        )
        self.max_gap = declare(
            self, 'max_gap', 1.0, 'Seconds between frames after which the target counts as lost.', low=0.0, high=3600.0
        )
        self.max_pending = declare(
            self,
            'max_pending',
            10,
            'Frames held while waiting for their masks; more are tracked without.',
            low=1,
            high=1000,
            read_only=True,
        )

        self.last_tracked_ns = -1
        self.tracked_at = (time.monotonic(), time.process_time())  # when the last frame's tracking began: wall, CPU
        self.stalls = 0  # gaps between frames of this node's own making
        self.last_result: TargetResult | None = None
        self.last_outcomes: list[TrackedTarget] = []
        # Frames waiting for their masks: stamp, arrival, image, header, the cues handed over with it,
        # its working frame.
        self.pending: deque[tuple[int, float, np.ndarray, Any, dict[str, np.ndarray | None], dict]] = deque()

        self.pose_pub = self.create_publisher(PoseWithCovarianceStamped, 'pose', RESULT_QOS)
        self.velocity_pub = self.create_publisher(TwistWithCovarianceStamped, 'velocity', RESULT_QOS)
        self.contour_pub = self.create_publisher(PolygonStamped, 'contour', RESULT_QOS)
        self.debug_pub = self.create_publisher(Image, 'debug_image', RESULT_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, 'markers', RESULT_QOS)
        self.targets_pub = self.create_publisher(Odometry, 'targets', RESULT_QOS) if len(kinds) > 1 else None
        self.markers_shown = False
        status_period = declare(
            self,
            'status_period',
            1.0,
            'Seconds between status messages while the state stays the same (each change is sent at once).',
            low=0.05,
            high=60.0,
            read_only=True,
        )
        self.status_pub = self.create_publisher(DiagnosticArray, 'status', LATCHED_QOS)
        self.status_header = Header()
        self.status_sent: tuple[str, str, bool] | None = None
        self.create_timer(status_period, self._publish_status, clock=self.steady_clock)
        self.requested_box: tuple[float, float, float, float] | None = None
        self.create_subscription(RegionOfInterest, 'init_roi', self._on_init_roi, RESULT_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.use_camera_info()
        depth_input = declare(
            self,
            'depth_input',
            False,
            'Subscribe depth (registered to the image, 16UC1 mm or 32FC1 m): the distance from it, not from the scale.',
            read_only=True,
        )
        self.surface_to_centre = declare(
            self,
            'surface_to_centre',
            _SURFACE_TO_CENTRE.get(target, 0.0),
            "Metres from the target's visible surface (what depth_input measures) back to its centre.",
            low=0.0,
            high=1.0,
        )
        # The mask topics each frame waits for; a pipeline hands the masks over with the frames,
        # but not the depth image.
        topics = [self.motion_input] if self.motion_input != 'none' else []
        topics += ['skin'] if skin_input else []
        self.mask_topics = (topics if subscribe_image else []) + (['depth'] if depth_input else [])
        self.masks: dict[str, OrderedDict[int, np.ndarray]] = {topic: OrderedDict() for topic in self.mask_topics}
        self.unmatched = dict.fromkeys(self.mask_topics, 0)
        # Frames a cue stage received but this node never did (lost on the way to it), told
        # apart from masks that came after their frame was received: the stamps of the last
        # _REMEMBERED_STAMPS frames that reached this node, in order (a dict as an ordered set).
        self.frames_never_received = 0
        self.frames_motion_set_aside = 0
        self.received_stamps: OrderedDict[int, None] = OrderedDict()
        # Masks queue as deep as the frames that may wait for them, so none is dropped.
        mask_qos = QoSProfile(
            depth=4 * self.max_pending, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST
        )
        self.mask_subscriptions = [
            self.create_subscription(Image, topic, lambda msg, topic=topic: self._on_mask(topic, msg), mask_qos)
            for topic in self.mask_topics
        ]
        self.frames_without_depth_reading = 0
        self.frames_without_colour = 0
        self.last_frame_grey = False
        self.last_distance: float | None = None  # measured on the last frame published
        if self.mask_topics:
            self.create_timer(0.02, self._drain, clock=self.steady_clock)
        self.start_problem: str | None = None
        if self.describing:
            return
        self.template = make_template(self.kind, num_points, template_file)
        templates = {kind: make_template(kind, num_points) for kind in kinds} | {self.kind: self.template}
        self.people = PersonTracker(
            kinds,
            filter_parameters,
            {self.kind: target_parameters},
            templates,
            max_people if len(kinds) > 1 else 1,
            id_hold_frames,
        )
        self.tracker = self.people.first(self.kind)
        self.primary = self.tracker  # the tracker of this frame's primary target
        if self.tracker.proposals_problem is not None:
            self.get_logger().warn(self.tracker.proposals_problem)
        if subscribe_image:
            self.check_start(motion=self.motion_input != 'none', skin=skin_input)
        self._publish_status()
        self.get_logger().info(
            f'configured: tracking {target} with {filter_parameters.num_particles} particles, '
            f'{self.template.num_points} points, mask inputs: {", ".join(self.mask_topics) or "none"}'
        )

    @property
    def uses_skin(self) -> bool:
        """Whether a target's tracker wants skin labels (a hand's)."""
        return 'hand' in self.kinds

    def check_start(self, *, motion: bool, skin: bool) -> None:
        """Say (log, diagnostics) when these inputs can never start the tracker by itself.

        Without ``init_box`` the filter starts from the region of ``init_region``: the motion
        mask or the skin labels. A node given neither waits for ever; it is told at start.
        """
        if self.init_box is not None or self.describing:
            return
        region = self.tracker.parameters.init_region
        if (region == 'motion' and not motion) or (region == 'skin' and not skin):
            needs = 'motion_input (foreground or motion)' if region == 'motion' else 'skin_input: true'
            self.start_problem = (
                f'cannot start by itself: init_region is {region} but no {region} input; set {needs}, or init_box'
            )
            self.get_logger().warn(self.start_problem)

    def warm_up(self) -> None:
        """Run the compiled kernels once, with this node's settings, so the first real frame is not late."""
        # Enough particles for a share of them to be drawn around a detection.
        filter_parameters = TrackerParameters(num_particles=10, min_scale=1.0)
        rng = np.random.default_rng(0)
        blank = np.zeros((32, 32), dtype=np.uint8)
        for tracker in self.people.trackers:
            if tracker.detector is not None:
                tracker.detector.load()
            probe = TargetTracker(tracker.template, filter_parameters, tracker.parameters)
            probe.initialise_from_box((8.0, 8.0, 16.0, 16.0))  # a box: the appearance kernels run too
            probe.process(rng.integers(0, 256, (32, 32, 3), dtype=np.uint8), blank, blank)
            # A detection (a face, a skin region) on a random frame is rare: its densities too.
            probe.filter.step(blank, detections=np.array([[16.0, 16.0, 16.0, 0.0]]))

    def unconnected_inputs(self) -> list[str]:
        """The mask topics no publisher is matched on yet: their first masks would be lost."""
        return [sub.topic_name for sub in self.mask_subscriptions if sub.get_publisher_count() == 0]

    def on_image(self, msg: Any) -> None:
        """Remember the stamp of every frame that reached this node, usable or not, then process it."""
        self.received_stamps[stamp_ns(msg.header)] = None
        while len(self.received_stamps) > _REMEMBERED_STAMPS:
            self.received_stamps.popitem(last=False)
        super().on_image(msg)

    def _apply_filter(self, parameters: TrackerParameters) -> None:
        for tracker in self.people.trackers:
            tracker.set_filter_parameters(parameters)

    def _apply_target(self, parameters: TargetParameters) -> None:
        self.tracker.parameters = parameters

    def reset_state(self) -> None:
        """Time went backwards: start over (the initial box applies again, held frames are dropped)."""
        self.people.reset()
        self.counters.skipped += len(self.pending)
        self.pending.clear()
        self.received_stamps.clear()
        for masks in self.masks.values():
            masks.clear()
        self.last_tracked_ns = -1
        self.last_distance = None

    def _on_mask(self, topic: str, msg: Image) -> None:
        try:
            mask = image_to_array(msg)
        except ImageConversionError as err:
            self.get_logger().warn(f'{topic} mask rejected: {err}', throttle_duration_sec=5.0)
            return
        masks = self.masks[topic]
        if topic == 'depth':
            if mask.ndim != 2 or mask.dtype not in (np.uint16, np.float32):
                self.counters.reject('depth_encoding')
                self.get_logger().warn(
                    f'depth image rejected: {msg.encoding}, not 16UC1 (mm) or 32FC1 (m)', throttle_duration_sec=5.0
                )
                return
            mask = depth_image_to_metres(mask)
        masks[stamp_ns(msg.header)] = mask if mask.ndim == 2 else mask[..., 0]
        while len(masks) > 4 * self.max_pending:
            masks.popitem(last=False)
        self._drain()

    def _drain(self) -> None:
        """Track held frames in order, each with its masks, or without those that waited too long."""
        now = time.monotonic()
        while self.pending:
            stamp, arrived, image, header, given, shared = self.pending[0]
            waiting = now - arrived < self.match_timeout and len(self.pending) <= self.max_pending
            if waiting and not self._has_masks(stamp):
                return
            self.pending.popleft()
            found = {topic: self.masks[topic].pop(stamp, None) for topic in self.mask_topics}
            for topic in (t for t, mask in found.items() if mask is None):
                self.unmatched[topic] += 1
                self.get_logger().warn(
                    f'frame tracked without its {topic} mask (none within {self.match_timeout} s)',
                    throttle_duration_sec=5.0,
                )
            cues = {**given, **found}
            start = time.perf_counter()
            self.guarded(
                self.track,
                image,
                header,
                cues.get(self.motion_input),
                cues.get('skin'),
                cues.get('depth'),
                shared,
                cues.get('camera_motion'),
            )
            self.timer_stats.took(time.perf_counter() - start)
        lost = set()
        oldest_known = next(iter(self.received_stamps), None)
        for masks in self.masks.values():
            for stale in [s for s in masks if s <= self.last_tracked_ns]:
                del masks[stale]
                # Older than every remembered stamp: unknown, so not counted.
                if stale not in self.received_stamps and oldest_known is not None and stale > oldest_known:
                    lost.add(stale)
        if lost:
            self.frames_never_received += len(lost)
            self.get_logger().warn(
                f'{len(lost)} frame(s) reached a cue stage but never this node (lost upstream)',
                throttle_duration_sec=5.0,
            )

    def _has_masks(self, stamp: int) -> bool:
        """Whether every mask the frame stamped ``stamp`` (ns) waits for has arrived."""
        return all(stamp in self.masks[topic] for topic in self.mask_topics)

    def handle_frame(
        self,
        image: np.ndarray,
        header: Any,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
        camera_motion: np.ndarray | None = None,
    ) -> object:
        """Track on one frame: now when no mask is expected (or they are given), else once they
        arrive. ``camera_motion``: the camera's motion onto this frame, camera pixels, as the
        in-process background stage measured it (``pipeline``)."""
        if self.mask_topics:
            given = {self.motion_input: motion, 'skin': skin, 'camera_motion': camera_motion}
            stamp = stamp_ns(header)
            shared: dict = {}
            if not self.pending and not self._has_masks(stamp):
                # The frame's own work (reduction, colour bins, edges: 1 of the tracker's 4 ms at
                # 640x480) is done while another node makes its masks, not after they arrive; not
                # while an earlier frame waits, whose masks may come meanwhile and would wait.
                with contextlib.suppress(Exception):  # tracking the frame meets the same error and reports it
                    shared = self.people.working_frame(image)
            self.pending.append((stamp, time.monotonic(), image, header, given, shared))
            self._drain()
            return DEFERRED
        return self.track(image, header, motion, skin, camera_motion=camera_motion)

    def track(
        self,
        image: np.ndarray,
        header: Any,
        motion: np.ndarray | None,
        skin: np.ndarray | None = None,
        depth: np.ndarray | None = None,
        shared: dict | None = None,
        camera_motion: np.ndarray | None = None,
    ) -> TargetResult | None:
        """Run the tracker on one frame and publish what it found under ``header`` (``shared``:
        its working frames computed beforehand, :meth:`PersonTracker.process`)."""
        stamp = stamp_ns(header)
        interval = (stamp - self.last_tracked_ns) / 1e9 if self.last_tracked_ns >= 0 else 0.0
        wall, cpu = time.monotonic(), time.process_time()
        if interval > self.max_gap:
            # After a gap the dynamics predict nothing: let motion restart the filter.
            for tracker in self.people.trackers:
                tracker.mark_lost()
            # A camera that paused leaves this process idle; a stall of the process's own (a
            # long computation) keeps it busy while the camera's frames are dropped. Measured
            # from the start of the last frame tracked, so its own processing is included.
            busy = (cpu - self.tracked_at[1]) / max(wall - self.tracked_at[0], 1e-6)
            if busy > 0.5:
                self.stalls += 1
                cause = f'this node was busy for {interval:.2f} s (its own stall: frames were dropped meanwhile)'
            else:
                cause = f'{interval:.2f} s since the last frame (the camera paused, or frames were lost)'
            self.get_logger().warn(f'{cause}: target marked lost', throttle_duration_sec=5.0)
        self.tracked_at = (wall, cpu)
        self.last_tracked_ns = stamp
        if self.uses_skin:
            self._check_colour(image)
        size = image.shape[:2]
        motion = self._of_frame(motion, size, 'mask', 'mask_size')
        skin = self._of_frame(skin, size, 'skin labels', 'skin_size')
        depth = self._of_frame(depth, size, 'depth image', 'depth_size')
        if self.requested_box is not None:
            box, self.requested_box = self.requested_box, None
            try:
                check_box_in_image(box, size)
                self.tracker.initialise_from_box(box)
                self.get_logger().info(f'started from the box on init_roi {box}')
            except ValueError as err:
                self.counters.reject('init_roi')
                self.get_logger().error(f'init_roi ignored: {err}')
        if self.init_box is not None and not self.tracker.filter.initialised:
            try:
                check_box_in_image(self.init_box, size)
                self.tracker.initialise_from_box(self.init_box)
            except ValueError as err:
                self.init_box = None
                self.start_problem = f'init_box ignored: {err}'
                self.get_logger().error(self.start_problem)
        outcomes = self.people.process(image, motion, skin, shared, camera_motion, stamp_ns=stamp)
        centre = (image.shape[1] / 2.0, image.shape[0] / 2.0)
        primary = primary_target(outcomes, self.kind, centre, self.get_parameter('primary_id').value)
        tracker = self.people.slot(primary.name).tracker
        if tracker is not self.primary:
            # Another person's head: the last distance was the other's.
            self.primary, self.last_distance = tracker, None
        result = primary.result
        self.last_result, self.last_outcomes = result, outcomes
        self.status_header = header
        if self._status_key() != self.status_sent:
            self._publish_status()
        if result.motion_set_aside:
            self.frames_motion_set_aside += 1
            self.get_logger().warn(
                'the motion mask covers most of the frame (camera moving, or light changed?): tracking on edges alone',
                throttle_duration_sec=5.0,
            )
        self.counters.processed += 1
        pose = None
        if result.tracking:
            pose = self._publish(result, header, size, interval, depth)
        else:
            self.last_distance = None
        if self.targets_pub is not None:
            self._publish_targets(outcomes, primary, header, size, depth, pose)
        if self.markers_pub.get_subscription_count() > 0:
            self._publish_markers(result, header, size)
        if self.debug_pub.get_subscription_count() > 0:
            estimate = result.estimate
            label = (
                result.status
                if estimate is None
                else f'{result.status} conf {estimate.confidence:.2f} motion {estimate.motion_support:.2f}'
                f' skin {estimate.skin_support:.2f} appearance {estimate.appearance_distance:.2f}'
            )
            if len(outcomes) > 1:
                label = f'{targets_line(outcomes)} | {primary.name}: {label}'
            debug = annotate(
                image,
                contour=None if estimate is None else estimate.contour,
                box=None if estimate is None else estimate.box,
                particles=self.primary.particles,
                label=label,
                motion=motion if motion is not None else skin,
                detections=tuple(d for o in outcomes for d in o.result.detections),
            )
            for outcome in outcomes:
                other = outcome.result.estimate
                if outcome is not primary and other is not None and outcome.result.tracking:
                    draw_target(debug, outcome.id, f'{outcome.kind} {outcome.id}', other.contour, other.box)
            self.debug_pub.publish(array_to_image(debug, 'bgr8', header))
        return result

    def _check_colour(self, image: np.ndarray) -> None:
        """Count a frame without colour (a hand's skin cannot be found in it); say so at the first."""
        grey = not has_colour(image)
        if grey and self.frames_without_colour == 0:
            self.get_logger().warn(GREY_INPUT_TEXT)
        self.frames_without_colour += int(grey)
        self.last_frame_grey = grey

    def warnings(self) -> list[str]:
        """The base's, a face detector the targets cannot have (dlib missing: a tracker other
        than the one configured), and a frame without colour for a hand."""
        found = super().warnings()
        found += sorted({t.proposals_problem for t in self.people.trackers if t.proposals_problem is not None})
        if self.last_frame_grey:
            found.append(f'GREY_INPUT: {GREY_INPUT_TEXT}')
        return found

    def _of_frame(self, mask: np.ndarray | None, size: tuple[int, ...], what: str, reason: str) -> np.ndarray | None:
        """``mask`` if it can be the frame of ``size`` at some resolution, else None (rejected as ``reason``).

        Cue stages publish at their own working width, so any resolution of the frame will do.
        """
        if mask is None or same_frame(mask.shape, size):
            return mask
        self.counters.reject(reason)
        self.get_logger().warn(
            f'{what} {mask.shape} cannot be image {size} at any resolution: tracking without it',
            throttle_duration_sec=5.0,
        )
        return None

    def _pose(
        self,
        tracker: TargetTracker,
        estimate: TrackEstimate,
        shape: tuple[int, ...],
        width: float,
        surface_to_centre: float,
        depth: np.ndarray | None,
    ) -> tuple[PoseWithCovariance, tuple[Any, ...], float | None, np.ndarray]:
        """The metric pose of ``tracker``'s ``estimate`` (a target ``width`` metres across,
        ``surface_to_centre`` metres deep) and its covariance; also the camera model, the distance
        used (metres: from ``depth`` when it has readings in the target's region, else None: from
        the scale) and the particles' positions."""
        assert tracker.particles is not None
        k, distortion = self.lens(shape[1], shape[0], self.image_rectified)
        measured = None
        if depth is not None:
            measured = region_depth(depth, box_from_state(estimate.state, tracker.template), shape[:2])
            if measured is None and tracker is self.primary:  # counted for the primary target's pose
                self.frames_without_depth_reading += 1
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
        fit_share = self.fit_residual_gain * estimate.position_error / reference_width
        covariance[:3, :3] = position_covariance(cloud, position, fit_share, width, spread)
        covariance[3, 3] = covariance[4, 4] = _UNKNOWN_VARIANCE
        covariance[5, 5] = estimate.covariance[3, 3]
        pose.covariance = covariance.reshape(-1).tolist()
        return pose, camera, distance, cloud

    def _publish(
        self, result: TargetResult, header: Any, shape: tuple[int, ...], interval: float, depth: np.ndarray | None
    ) -> PoseWithCovariance:
        """The pose and contour; the velocity too when the frame before is ``interval`` s back.
        With a ``depth`` image (metres) the distance is its readings' in the target's region.
        Returns the pose published."""
        estimate = result.estimate
        particles, previous = self.primary.particles, self.primary.previous_particles
        assert estimate is not None and particles is not None and previous is not None
        pose = PoseWithCovarianceStamped()
        pose.header = header
        pose.pose, camera, distance, cloud = self._pose(
            self.primary, estimate, shape, self.target_width, self.surface_to_centre, depth
        )
        self.pose_pub.publish(pose)
        # Distances of the same kind on both frames: measured on both, or both from the scale.
        previous_distance, self.last_distance = self.last_distance, distance
        if interval > 0:
            both = distance is not None and previous_distance is not None
            now = cloud if both or distance is None else metric_positions(particles, *camera)
            before = metric_positions(previous, *camera, depth=previous_distance if both else None)
            self.velocity_pub.publish(_velocity(header, now, before, previous, particles, interval))
        contour = PolygonStamped()
        contour.header = header
        contour.polygon.points = [Point32(x=float(x), y=float(y), z=0.0) for x, y in estimate.contour]
        self.contour_pub.publish(contour)
        return pose.pose

    def _publish_targets(
        self,
        outcomes: list[TrackedTarget],
        primary: TrackedTarget,
        header: Any,
        shape: tuple[int, ...],
        depth: np.ndarray | None,
        primary_pose: PoseWithCovariance | None,
    ) -> None:
        """One Odometry on ``targets`` per target TRACKING on this frame, named by its person, kind
        and id; the ``primary`` target's pose is the one ``pose`` got (``primary_pose``)."""
        for outcome in outcomes:
            if not outcome.result.tracking:
                continue
            odometry = Odometry()
            odometry.header = header
            odometry.child_frame_id = f'person_{outcome.person}/{outcome.kind}_{outcome.id}'
            if outcome is primary:
                assert primary_pose is not None  # published on pose: the primary target is TRACKING
                odometry.pose = primary_pose
            else:
                estimate = outcome.result.estimate
                assert estimate is not None
                tracker, kind = self.people.slot(outcome.name).tracker, outcome.kind
                odometry.pose = self._pose(
                    tracker, estimate, shape, _TARGET_WIDTHS[kind], _SURFACE_TO_CENTRE[kind], depth
                )[0]
            odometry.twist.covariance = (np.eye(6) * _UNKNOWN_VARIANCE).reshape(-1).tolist()
            self.targets_pub.publish(odometry)

    def _publish_markers(self, result: TargetResult, header: Any, shape: tuple[int, ...]) -> None:
        """The target's contour and label for RViz while the filter has an estimate; cleared once when it has none."""
        estimate = result.estimate
        if estimate is None:
            if self.markers_shown:
                self.markers_pub.publish(cleared_markers(header))
                self.markers_shown = False
            return
        k, distortion = self.lens(shape[1], shape[0], self.image_rectified)
        depth = self.last_distance  # this frame's measured distance, when it was published with one
        if depth is None or not result.tracking:
            depth = float(metric_positions(estimate.state, self.template, k, self.target_width)[2])
        contour = undistort_pixels(estimate.contour, k, distortion)
        markers = target_markers(header, contour, depth, k, kind=self.kind, ident=0, status=result.status)
        self.markers_pub.publish(markers)
        self.markers_shown = True

    def _on_init_roi(self, msg: RegionOfInterest) -> None:
        """Start from this box (x, y, w, h, the image's pixels) on the next frame."""
        if msg.width == 0 or msg.height == 0:
            self.counters.reject('init_roi')
            self.get_logger().error(f'init_roi ignored: an empty box ({msg.width} x {msg.height})')
            return
        self.requested_box = (float(msg.x_offset), float(msg.y_offset), float(msg.width), float(msg.height))

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Forget the target; the start box does not apply again (it was the first frame's)."""
        self.people.reset()
        self.init_box = self.requested_box = None
        self.last_result, self.last_outcomes = None, []
        self._publish_status()
        response.success = True
        response.message = 'WAITING for motion, or a box on init_roi'
        return response

    def _publish_status(self) -> None:
        """The tracker's state and its cues' support, stamped with the last frame tracked."""
        state = self.primary.status
        values = self._target_values()
        warnings = self.warnings()
        if warnings:
            values['warnings'] = '; '.join(warnings)
        level = DiagnosticStatus.WARN if state == LOST or warnings else DiagnosticStatus.OK
        status = node_status(self, state, values, level=level)
        self.status_pub.publish(DiagnosticArray(header=self.status_header, status=[status]))
        self.status_sent = self._status_key()

    def _status_key(self) -> tuple[str, str, bool]:
        """What a status message is sent at once on a change of: the state and the shape (a
        hand opening or closing is a gesture)."""
        estimate = None if self.last_result is None else self.last_result.estimate
        return self.primary.status, '' if estimate is None else estimate.shape, self.last_frame_grey

    def _target_values(self) -> dict[str, str]:
        """The last estimate's shape, confidence and per-cue support (empty without one)."""
        result = self.last_result
        if result is None or result.estimate is None:
            return {}
        estimate = result.estimate
        return {
            'shape': estimate.shape,
            'confidence': f'{estimate.confidence:.3f}',
            'motion_support': f'{estimate.motion_support:.3f}',
            'skin_support': f'{estimate.skin_support:.3f}',
            'appearance_distance': f'{estimate.appearance_distance:.3f}',
            'effective_sample_size': f'{estimate.effective_sample_size:.1f}',
        }

    def diagnostics_state(self) -> tuple[str, dict[str, Any]]:
        extra: dict[str, Any] = {
            'particles': self.tracker.filter.parameters.num_particles,
            **{f'frames_without_{topic}': count for topic, count in self.unmatched.items()},
            'frames_never_received': self.frames_never_received,
            'frames_motion_set_aside': self.frames_motion_set_aside,
            'frames_pending': len(self.pending),
            'frames_without_depth_reading': self.frames_without_depth_reading,
            'frames_without_colour': self.frames_without_colour,
            'stalls': self.stalls,
        }
        if self.start_problem is not None:
            extra['cannot_start'] = self.start_problem
        if len(self.people.kinds) > 1:
            extra['targets'] = targets_line(self.last_outcomes)
        return self.primary.status, {**extra, **self._target_values()}


def _velocity(
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
    covariance[3, 3] = covariance[4, 4] = _UNKNOWN_VARIANCE
    covariance[5, 5] = float(turn.var())
    twist.twist.covariance = covariance.reshape(-1).tolist()
    return twist


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker tracker_node``; returns the exit code."""
    return spin_node(TrackerNode, args, name='tracker_node', summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
