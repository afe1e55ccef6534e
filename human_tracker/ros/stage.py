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

import array
import dataclasses
import functools
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
import rclpy
import rclpy.logging
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosbags.serde import SerdeError
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_msgs.msg import Bool, Header

from human_tracker.io.images import stamp_ns
from human_tracker.ros.common import (
    LATCHED_QOS,
    RESULT_QOS,
    FrameCounters,
    PublisherSequence,
    StageTimer,
    declare,
    diagnostic_status,
    image_qos,
    init_without_signal_handlers,
    publish_diagnostics,
    shutdown,
    spin_until,
    stop_on_signals,
)
from human_tracker.ros.image_conversion import ImageConversionError, message_to_bgr8
from human_tracker.ros.startup import (
    StartError,
    check_configuration,
    declare_strict,
    quiet_discovery,
    usage,
    without_help,
)
from human_tracker.threads import default_threads, use_threads
from human_tracker.vision.cues.stages import Frame
from human_tracker.vision.geometry.camera import default_camera_matrix

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ['DEFERRED', 'ParameterSpec', 'ImageStage', 'run_nodes', 'spin_node', 'stamp_ns']

DEFERRED = object()
"""Returned by ``handle_frame`` for a frame held for later (it is timed when processed)."""

# Seconds a warmed-up stage waits for publishers on its inputs before it says ready anyway.
INPUT_WAIT = 30.0

# camera_info's distortion models whose coefficients are OpenCV's (k1, k2, p1, p2, k3, ...).
_OPENCV_DISTORTION_MODELS = ('plumb_bob', 'rational_polynomial')


@functools.cache
def _typestore() -> Typestore:
    """rosbags' Jazzy message types, imported on first use: a quarter of a second that a node
    answering ``--help`` need not pay (a stage loads it while it warms up)."""
    from human_tracker.io.bags import TYPESTORE

    return TYPESTORE


def _plain(value: Any) -> Any:
    """Array parameters arrive as lists or array.array; the dataclasses hold tuples."""
    return tuple(value) if isinstance(value, (list, tuple, array.array)) else value


@dataclass(frozen=True)
class ParameterSpec:
    """How one field of an algorithm's parameter dataclass appears as a ROS parameter.

    Attributes:
        field: Field name in the dataclass (also the ROS parameter name).
        description: What it means, with unit and the paper's symbol.
        low: Lower bound for numbers (None: no range declared).
        high: Upper bound for numbers.
        runtime: Whether it may change while the node runs.
    """

    field: str
    description: str
    low: float | None = None
    high: float | None = None
    runtime: bool = True


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
        self.camera_matrix: np.ndarray | None = None
        self.rectified_matrix: np.ndarray | None = None
        self.distortion: np.ndarray | None = None
        # Each bound dataclass: its ROS names' fields, its current value, and how a change is applied.
        self._bindings: list[tuple[dict[str, str], Callable[[], Any], Callable[[Any], None]]] = []
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
        self.ready_pub = self.create_publisher(Bool, '~/ready', LATCHED_QOS)
        # Fires once the executor spins, that is after every subclass has finished building.
        self._ready_timer = self.create_timer(0.01, self._become_ready, clock=self.steady_clock)
        self.add_on_set_parameters_callback(self._on_set_parameters)
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
        if subscribe_image:
            transport = declare(
                self,
                'image_transport',
                'raw',
                'Image input: raw (image) or compressed (image/compressed).',
                read_only=True,
            )
            if transport not in ('raw', 'compressed'):
                raise ValueError(f"image_transport must be 'raw' or 'compressed', got {transport!r}")
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
        self.ready_pub.publish(Bool(data=True))
        self.get_logger().info('ready')

    def bind_parameters(
        self, instance: Any, specs: Sequence[ParameterSpec], apply: Callable[[Any], None], prefix: str = ''
    ) -> Any:
        """Declare ``specs`` (as ``prefix`` + field: ``hand.lost_frames``) from the dataclass
        ``instance``'s defaults; return it with the declared values.

        Run-time changes build a new instance, call its ``validate()`` and, if it passes,
        hand it to ``apply``; otherwise the change is refused with the validation message.
        """
        values = {}
        for spec in specs:
            default = getattr(instance, spec.field)
            if isinstance(default, tuple):
                default = list(default)
            value = declare(
                self,
                prefix + spec.field,
                default,
                spec.description,
                low=spec.low,
                high=spec.high,
                read_only=not spec.runtime,
            )
            values[spec.field] = tuple(value) if isinstance(default, list) else value
        bound = dataclasses.replace(instance, **values)
        bound.validate()
        current = {'value': bound}

        def commit(new: Any) -> None:
            current['value'] = new
            apply(new)

        fields = {prefix + spec.field: spec.field for spec in specs}
        self._bindings.append((fields, lambda: current['value'], commit))
        return bound

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        for fields, get, commit in self._bindings:
            changes = {fields[p.name]: _plain(p.value) for p in parameters if p.name in fields}
            if not changes:
                continue
            candidate = dataclasses.replace(get(), **changes)
            try:
                candidate.validate()
            except ValueError as err:
                return SetParametersResult(successful=False, reason=str(err))
            commit(candidate)
            self.get_logger().info(f'parameters changed: {changes}')
        return SetParametersResult(successful=True)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.active = True
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
        """Subscribe ``camera_info``; :meth:`intrinsics` then returns its K."""
        self.create_subscription(CameraInfo, 'camera_info', self._on_camera_info, RESULT_QOS)

    def _on_camera_info(self, msg: CameraInfo) -> None:
        k = np.asarray(msg.k, dtype=np.float64).reshape(3, 3)
        if k[0, 0] > 0 and k[1, 1] > 0:
            self.camera_matrix = k
            self.rectified_matrix = np.asarray(msg.p, dtype=np.float64).reshape(3, 4)[:, :3]
        self.distortion = None
        if np.any(msg.d):
            if msg.distortion_model in _OPENCV_DISTORTION_MODELS:
                self.distortion = np.asarray(msg.d, dtype=np.float64)
            else:
                self.get_logger().warn(
                    f'camera_info distortion model {msg.distortion_model!r} is not supported: pixels taken '
                    'as undistorted (feed a rectified image, with image_rectified: true)',
                    throttle_duration_sec=60.0,
                )

    def lens(self, width: int, height: int, rectified: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """K and the distortion coefficients D of ``camera_info`` for a raw image; for a rectified
        one, P's intrinsics and no distortion (ROS's convention); the default K until one arrives."""
        if self.camera_matrix is None:
            return default_camera_matrix(width, height), None
        if rectified:
            usable = self.rectified_matrix is not None and self.rectified_matrix[0, 0] > 0
            return (self.rectified_matrix if usable else self.camera_matrix), None
        return self.camera_matrix, self.distortion

    def intrinsics(self, width: int, height: int) -> np.ndarray:
        """K from ``camera_info``, or the documented default (60° pinhole) until one arrives."""
        return self.lens(width, height, rectified=False)[0]

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

    def _publish_diagnostics(self) -> None:
        state, extra = self.diagnostics_state()
        extra = {'ready': self.ready, 'threads': self.threads, 'time_resets': self.time_resets, **extra}
        warnings = self.warnings()
        level = None
        if warnings:
            extra['warnings'], level = '; '.join(warnings), DiagnosticStatus.WARN
        status = diagnostic_status(self, self.counters, self.timer_stats, state=state, level=level, extra=extra)
        publish_diagnostics(self, self.diagnostics_pub, [status])


def run_nodes(
    build: Callable[[], list[Node]],
    args: list[str] | None = None,
    *,
    name: str = 'node',
    run: Callable[[list[Node]], None] | None = None,
    summary: str = '',
) -> int:
    """Init rclpy, build the nodes, run them until SIGINT or SIGTERM; return the exit code.

    By default the nodes are spun in this thread. With ``run``, ``run(nodes)`` works in this
    thread while they are spun in another (their timers, services and parameters keep
    answering) until it returns.

    ``-h`` / ``--help`` prints the nodes' parameters (defaults, ranges, descriptions) and
    topics, with ``summary`` above them, and exits 0: the nodes are built with discovery off
    and never spun. Malformed ROS arguments, a missing or unparseable parameter file, a
    parameter or parameter-file section that no node declares (unless ``strict:=false``: a
    warning, also in ``/diagnostics``), a ValueError or an rclpy parameter error while
    building or running (a value out of range or of the wrong type, a missing file): one line
    with the reason and exit code 2, no traceback.

    A signal stops the spinning between two callbacks (see
    :func:`~human_tracker.ros.common.stop_on_signals`); the nodes are then destroyed and rclpy
    shut down here, in order. Ctrl-C exits with 0.
    """
    argv, wants_help = without_help(sys.argv if args is None else args)
    if wants_help:
        return _print_usage(build, argv, name, summary)
    try:
        init_without_signal_handlers(argv)
    except StartError as err:
        print(f'{name}: cannot start: {err}', file=sys.stderr)
        return 2
    nodes: list[Node] = []
    executor = SingleThreadedExecutor()
    spinner: threading.Thread | None = None
    code = 0
    with stop_on_signals(interrupt=run is not None) as stop:
        try:
            nodes = build()
            check_configuration(nodes, argv)
            for node in nodes:
                executor.add_node(node)
            if run is None:
                spin_until(executor, stop)
            else:
                spinner = threading.Thread(target=spin_until, args=(executor, stop))
                spinner.start()
                run(nodes)
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        except (ValueError, ParameterException) as err:
            rclpy.logging.get_logger(name).error(f'cannot start: {err}')
            code = 2
        finally:
            stop.set()
            if spinner is not None:
                # The spinning thread must end before its nodes and the context go away.
                spinner.join()
            # The order of rclpy.spin: detach the nodes from the executor before destroying them.
            for node in nodes:
                executor.remove_node(node)
                node.destroy_node()
            executor.shutdown()
            shutdown()
    return code


def _print_usage(build: Callable[[], list[Node]], argv: list[str], name: str, summary: str) -> int:
    quiet_discovery()
    nodes: list[Node] = []
    try:
        # The nodes are built, not run: what they log while being built is not the answer.
        init_without_signal_handlers([*argv, '--ros-args', '--log-level', 'fatal'])
        ImageStage.describing = True
        nodes = build()
        for node in nodes:
            declare_strict(node)
        print(usage(name, nodes, summary))
    except (ValueError, ParameterException) as err:
        print(f'{name}: cannot start: {err}', file=sys.stderr)
        return 2
    finally:
        for node in nodes:
            node.destroy_node()
        shutdown()
    return 0


def spin_node(factory: Callable[[], Node], args: list[str] | None, *, name: str, summary: str = '') -> int:
    """Spin the one node ``factory`` makes; ``name`` is the executable's (see :func:`run_nodes`)."""
    return run_nodes(lambda: [factory()], args, name=name, summary=summary)
