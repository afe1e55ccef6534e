"""The base of every image-processing node: input, accounting, diagnostics, parameters, readiness.

A stage subscribes to ``image`` (or ``image/compressed``) unless a pipeline hands it frames
in memory, converts each message once, counts every frame (processed, skipped, rejected),
publishes ``/diagnostics`` periodically, and binds its algorithm's parameter dataclass to
declared ROS parameters whose run-time changes are validated before they take effect.

Readiness: once its executor spins, a stage compiles its kernels (:meth:`ImageStage.warm_up`)
and, once each input it waits for (:meth:`ImageStage.unconnected_inputs`: a tracker's
masks from other nodes) has a publisher matched, or after :data:`INPUT_WAIT` seconds, publishes
``True`` on ``~/ready`` (std_msgs/Bool, transient local) and ``ready`` in ``/diagnostics``. A
replay or a test starts feeding frames only then: a subscriber that exists is not yet a node
that keeps up, and a mask published before its subscriber matched is lost.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rosbags.serde import SerdeError
from sensor_msgs.msg import CompressedImage, Image
from std_msgs.msg import Bool, Header

from human_tracker.io.images import stamp_ns
from human_tracker.ros.camera_info import CameraInfoInput
from human_tracker.ros.common import (
    LATCHED_QOS,
    RESULT_QOS,
    FrameCounters,
    PublisherSequence,
    StageTimer,
    declare,
    diagnostic_status,
    image_qos,
    publish_diagnostics,
)
from human_tracker.ros.image_conversion import ImageConversionError, message_to_bgr8
from human_tracker.ros.parameter_binding import ParameterBindings
from human_tracker.ros.startup import PACKAGE_NODES
from human_tracker.threads import default_threads, use_threads
from human_tracker.vision.cues.stages import Frame

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ['DEFERRED', 'ImageStage', 'stamp_ns']

DEFERRED = object()
"""Returned by ``handle_frame`` for a frame held for later (it is timed when processed)."""

# Seconds a warmed-up stage waits for publishers on its inputs before it says ready anyway.
INPUT_WAIT = 30.0
# Seconds without a frame after ready before a stage says where it listens and what is published.
NO_INPUT_WAIT = 5.0


@functools.cache
def _typestore() -> Typestore:
    """rosbags' Jazzy message types, imported on first use: a quarter of a second that a node
    answering ``--help`` need not pay (a stage loads it while it warms up)."""
    from human_tracker.io.bags import TYPESTORE

    return TYPESTORE


class ImageStage(LifecycleNode):
    """A node that processes camera frames; subclasses implement :meth:`handle_frame`.

    Every stage is a lifecycle node. By default it configures and activates itself at once and
    runs like a plain node; with ``managed: true`` it waits, unconfigured, for a lifecycle
    manager (``~/change_state``: configure, activate, deactivate, cleanup). While not active
    it drops each frame on arrival, before any conversion (counted as skipped and
    ``inactive``); cleanup forgets what it learnt (the target, the background). In a pipeline
    the camera subscriber is the input: managing it manages the pipeline.
    """

    describing = False
    """Set while ``--help`` builds the nodes: a stage declares its parameters and topics but
    builds none of its algorithm's state (a tracker's templates take a second to build)."""

    def __init__(self, name: str, *, subscribe_image: bool = True, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.active = False
        self.counters = FrameCounters()
        self._sequence = PublisherSequence()
        self.timer_stats = StageTimer()
        self.last_stamp_ns = -1
        self.time_resets = 0
        self.parameter_bindings = ParameterBindings(self)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', RESULT_QOS)
        period = declare(
            self,
            'diagnostics_period',
            1.0,
            'Seconds between /diagnostics messages.',
            low=0.05,
            high=60.0,
            read_only=True,
        )
        # Wall-clock timers: under use_sim_time a paused or finished replay stops /clock,
        # and diagnostics (and the tracker's bounded waits) must go on.
        self.steady_clock = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(period, self._publish_diagnostics, clock=self.steady_clock)
        threads = declare(
            self,
            'threads',
            default_threads(),
            'Threads of the parallel loops (numba, OpenCV) in this process; 0: every core. A busy '
            'robot computer keeps a steadier frame rate with 1 (default: HUMAN_TRACKER_THREADS, else 1).',
            low=0,
            high=1024,
            read_only=True,
        )
        self.threads = use_threads(threads)
        self.configuration_problems: list[str] = []
        self.ready = False
        self._spinning = False
        self.ready_pub = self.create_publisher(Bool, '~/ready', LATCHED_QOS)
        # Fires once the executor spins, that is after every subclass has finished building.
        self._ready_timer = self.create_timer(0.01, self._become_ready, clock=self.steady_clock)
        managed = declare(
            self,
            'managed',
            False,
            'Wait, unconfigured, for a lifecycle manager (configure, activate) instead of running at once.',
            read_only=True,
        )
        if not managed:
            self.trigger_configure()
            self.trigger_activate()
        self._image_input = None
        self._ready_at = 0.0
        if subscribe_image:
            transport = self.image_transport = declare(
                self,
                'image_transport',
                'raw',
                'Image input: raw (image) or compressed (image/compressed).',
                read_only=True,
            )
            if transport not in ('raw', 'compressed'):
                raise ValueError(f"image_transport must be 'raw' or 'compressed', got {transport!r}")
            self.no_input_wait = declare(
                self,
                'no_input_warning',
                NO_INPUT_WAIT,
                'Seconds without a frame after ready before the node says which topic it listens on and which '
                'image topics the graph has (log and /diagnostics); 0: never.',
                low=0.0,
                high=3600.0,
                read_only=True,
            )
            qos = image_qos(self)
            # Raw (serialised) messages: on_wire_image reads them without copying the pixels.
            if transport == 'compressed':
                on_compressed = partial(self._on_sent_image, 'sensor_msgs/msg/CompressedImage')
                self._image_input = self.create_subscription(
                    CompressedImage, 'image/compressed', on_compressed, qos, raw=True
                )
            else:
                on_raw = partial(self._on_sent_image, 'sensor_msgs/msg/Image')
                self._image_input = self.create_subscription(Image, 'image', on_raw, qos, raw=True)

    def warm_up(self) -> None:
        """Compile and run the stage's kernels once on a small frame, so the first real frame is not late."""

    def _become_ready(self) -> None:
        self._ready_timer.cancel()
        self.destroy_timer(self._ready_timer)
        self._spinning = True
        if self.active:
            self.get_logger().info('active')
        # A first run compiles for tens of seconds: say why the node is not ready yet.
        self.get_logger().info('warming up: compiling and running the kernels once')
        start = time.perf_counter()
        _typestore()
        self.warm_up()
        self.get_logger().info(f'warmed up in {time.perf_counter() - start:.1f} s')
        self._input_deadline = time.monotonic() + INPUT_WAIT
        self._ready_timer = self.create_timer(0.05, self._say_ready_once_connected, clock=self.steady_clock)

    def unconnected_inputs(self) -> list[str]:
        """Input topics this stage waits for and that have no matched publisher yet (none by default)."""
        return []

    def _say_ready_once_connected(self) -> None:
        missing = self.unconnected_inputs()
        if missing and time.monotonic() < self._input_deadline:
            return
        self._ready_timer.cancel()
        self.destroy_timer(self._ready_timer)
        if missing:
            self.get_logger().warn(
                f'ready without a publisher on {", ".join(missing)} after {INPUT_WAIT:.0f} s: '
                'frames are tracked without those inputs until one comes'
            )
        self.ready = True
        self._ready_at = time.monotonic()
        self.ready_pub.publish(Bool(data=True))
        self.get_logger().info('ready')

    def bind_parameters(self, instance: Any, apply: Callable[[Any], None], prefix: str = '') -> Any:
        """:meth:`ParameterBindings.bind` on this node's parameters."""
        return self.parameter_bindings.bind(instance, apply, prefix)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = True
        if self._spinning:  # an unmanaged node activates while it is built: said once it runs
            self.get_logger().info('active')
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = False
        self.get_logger().info('inactive: frames are dropped on arrival')
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.reset_state()
        self.last_stamp_ns = -1
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = False
        return TransitionCallbackReturn.SUCCESS

    def _on_sent_image(self, typename: str, data: bytes, info: dict[str, Any]) -> None:
        """An image from the subscription, with its message info: the frames sent before it that
        never arrived are counted as dropped, then it is read (:meth:`on_wire_image`)."""
        sequence = info.get('publication_sequence_number')
        self.counters.dropped += self._sequence.missed(sequence, self._image_input.get_publisher_count())
        self.on_wire_image(typename, data)

    def on_wire_image(self, typename: str, data: bytes) -> None:
        """Read one serialised (CDR) image message of ``typename`` and process it (:meth:`on_image`).

        rosbags' deserialiser leaves the pixels a view of ``data``, where rclpy's message copies
        them into an array.array (0.05 ms against 0.4 for 640x480 bgr8). A message that cannot
        be read is counted and logged as a rejected conversion.
        """
        try:
            msg = _typestore().deserialize_cdr(data, typename)
        except SerdeError as err:
            self.counters.received += 1
            self.counters.reject('conversion')
            self.get_logger().warn(f'frame rejected: {err}', throttle_duration_sec=5.0)
            return
        # Outputs copy the header: it must be rclpy's.
        header = Header(frame_id=msg.header.frame_id)
        header.stamp.sec, header.stamp.nanosec = msg.header.stamp.sec, msg.header.stamp.nanosec
        msg.header = header
        self.on_image(msg)

    def on_image(self, msg: Any) -> None:
        """Convert one image message and process it; a bad frame is counted and logged, never fatal.

        While the node is not active the frame is counted and dropped, unconverted."""
        if not self.active:
            self.counters.received += 1
            self.counters.skipped += 1
            self.counters.inactive += 1
            return
        try:
            image = message_to_bgr8(msg)
        except ImageConversionError as err:
            self.counters.received += 1
            self.counters.reject('conversion')
            self.get_logger().warn(f'frame rejected: {err}', throttle_duration_sec=5.0)
            return
        self.process_frame(image, msg.header)

    def process_frame(self, image: np.ndarray, header: Any, **cues: Any) -> object:
        """Count, time and process one converted frame (the pipeline calls this directly).

        Time is checked first: a frame stamped like the last one is a duplicate (skipped and
        counted); a stamp earlier than the last one (a bag replay that loops, a clock reset)
        starts a new sequence: the stage's state is reset (counted) and the frame processed.
        """
        self.counters.received += 1
        self.timer_stats.arrived()
        stamp = stamp_ns(header)
        if stamp == self.last_stamp_ns:
            self.counters.skipped += 1
            self.get_logger().warn('frame skipped: same stamp as the previous frame', throttle_duration_sec=5.0)
            return None
        if stamp < self.last_stamp_ns:
            self.time_resets += 1
            self.get_logger().warn(
                f'time went back by {(self.last_stamp_ns - stamp) / 1e9:.3f} s (replay loop or clock reset): '
                'state reset',
                throttle_duration_sec=5.0,
            )
            self.reset_state()
        self.last_stamp_ns = stamp
        start = time.perf_counter()
        result = self.guarded(self.handle_frame, image, header, **cues)
        if result is not DEFERRED:
            self.timer_stats.took(time.perf_counter() - start)
        return result

    def frame(self, image: np.ndarray, header: Any) -> Frame:
        """``image`` as the frame path takes it (:class:`~human_tracker.vision.cues.stages.Frame`): with its stamp."""
        return Frame(image, stamp_ns(header))

    def use_camera_info(self) -> None:
        """Subscribe ``camera_info``: :attr:`camera` then has its intrinsics."""
        self.camera = CameraInfoInput(self)

    def guarded(self, work: Callable[..., object], *args: Any, **kwargs: Any) -> object:
        """Run ``work``; an unexpected error is counted as a rejected frame and logged, never raised.

        A perception node must outlive one bad frame: everything that processes a frame goes
        through here, whichever callback it runs in.
        """
        try:
            return work(*args, **kwargs)
        except Exception as err:
            self.counters.reject(f'error_{type(err).__name__}')
            self.get_logger().error(
                f'frame failed ({type(err).__name__}: {err}); going on with the next', throttle_duration_sec=5.0
            )
            return None

    def handle_frame(self, image: np.ndarray, header: Any, **cues: Any) -> object:
        """Process one ``(H, W, 3) uint8`` BGR frame stamped with ``header``; ``cues`` come from a pipeline.

        Implementations count it as processed or skipped in ``self.counters``.
        """
        raise NotImplementedError

    def reset_state(self) -> None:
        """Forget everything learnt from earlier frames (time went backwards)."""

    def diagnostics_state(self) -> tuple[str, dict[str, Any]]:
        """The state word and extra key-values for /diagnostics."""
        return 'OK', {}

    def warnings(self) -> list[str]:
        """What is wrong now (a parameter ignored, an input without colour, a cue that cannot
        run): ``/diagnostics`` says it, at WARN level."""
        return list(self.configuration_problems)

    def input_problem(self) -> str | None:
        """Why this node has processed nothing, once no frame has reached it for ``no_input_warning``
        seconds after it said ready: the topic and transport it listens on, and the image topics
        the graph has (the likely fix: a remap or ``image_transport``); None while frames come."""
        if self._image_input is None or not self.ready or not self.active or self.counters.received > 0:
            return None
        waited = time.monotonic() - self._ready_at
        if self.no_input_wait <= 0 or waited < self.no_input_wait:
            return None
        topic = self._image_input.topic_name
        found = [
            f'{name} ({"compressed" if "sensor_msgs/msg/CompressedImage" in types else "raw"})'
            for name, types in self.get_topic_names_and_types()
            if {'sensor_msgs/msg/Image', 'sensor_msgs/msg/CompressedImage'} & set(types) and self._camera_like(name)
        ]
        graph = f'image topics on the graph: {", ".join(found)}' if found else 'no image topic on the graph'
        hint = ' (image_transport:=compressed reads */compressed; remap image:=TOPIC)' if found else ''
        return (
            f'no frame for {waited:.0f} s on {topic} ({self.image_transport}, '
            f'{self.count_publishers(topic)} publishers); {graph}{hint}'
        )

    def _camera_like(self, topic: str) -> bool:
        """Whether ``topic`` has a publisher other than this package's nodes (whose images are
        masks and debug views, not a camera)."""
        publishers = self.get_publishers_info_by_topic(topic)
        return any(info.node_name not in PACKAGE_NODES for info in publishers)

    def _publish_diagnostics(self) -> None:
        state, extra = self.diagnostics_state()
        extra = {'ready': self.ready, 'threads': self.threads, 'time_resets': self.time_resets, **extra}
        warnings = self.warnings()
        problem = self.input_problem()
        if problem is not None:
            warnings.append(f'NO_INPUT: {problem}')
            self.get_logger().warn(problem, throttle_duration_sec=30.0)
        level = None
        if warnings:
            extra['warnings'], level = '; '.join(warnings), DiagnosticStatus.WARN
        status = diagnostic_status(self, self.counters, self.timer_stats, state=state, level=level, extra=extra)
        publish_diagnostics(self, self.diagnostics_pub, [status])
