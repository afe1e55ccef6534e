"""What every node shares: declared parameters with ranges, QoS from parameters, frame
accounting, diagnostics, and an orderly stop on SIGINT / SIGTERM."""

from __future__ import annotations

import signal
import sys
import threading
import time
import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions

from human_tracker.ros.startup import init_rclpy
from human_tracker.vision.checks import description_of
from human_tracker.vision.track.parameters import FrameParameters

__all__ = [
    'declare',
    'as_declared',
    'LATCHED_QOS',
    'declare_working_width',
    'WORKING_WIDTH_DESCRIPTION',
    'image_qos',
    'RESULT_QOS',
    'FrameCounters',
    'PublisherSequence',
    'StageTimer',
    'diagnostic_status',
    'node_status',
    'publish_diagnostics',
    'shutdown',
    'init_without_signal_handlers',
    'stop_on_signals',
    'spin_until',
    'STOP_POLL_SECONDS',
]

RESULT_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
"""Results (poses, masks, contours) are published reliably."""

LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""States a late subscriber must still get (``~/ready``): reliable, transient local, the last one."""

# The Python type of each parameter declared through `declare`, per node: what a value given
# as another type (an integer for a double) is converted to.
_DECLARED_KINDS: weakref.WeakKeyDictionary[Node, dict[str, type]] = weakref.WeakKeyDictionary()


def as_declared(parameter: Parameter, kind: type) -> Parameter:
    """``parameter`` converted to ``kind`` where the command line's syntax is the only difference.

    ``-p init_box:="[1, 2, 3, 4]"`` arrives as an integer array and ``-p source:=0`` as an
    integer; a user means a double array and a string. Other types are left for rclpy to refuse.
    """
    value, types = parameter.value, Parameter.Type
    if kind is float and parameter.type_ == types.INTEGER:
        return Parameter(parameter.name, types.DOUBLE, float(value))
    if kind is list and parameter.type_ == types.INTEGER_ARRAY:
        return Parameter(parameter.name, types.DOUBLE_ARRAY, [float(v) for v in value])
    if kind is str and parameter.type_ == types.INTEGER:
        return Parameter(parameter.name, types.STRING, str(value))
    return parameter


def _accept_other_syntax(node: Node, name: str, default: Any) -> None:
    """Let ``name`` take integers for a double (array) or a string, at start and at run time."""
    if isinstance(default, bool) or not isinstance(default, (float, str, list)):
        return
    if isinstance(default, list) and not all(isinstance(v, float) for v in default):
        return
    kinds = _DECLARED_KINDS.get(node)
    if kinds is None:
        kinds = _DECLARED_KINDS[node] = {}
        node.add_pre_set_parameters_callback(
            lambda parameters: [as_declared(p, kinds[p.name]) if p.name in kinds else p for p in parameters]
        )
    kinds[name] = type(default)
    # Values given at start (command line, YAML) do not pass the pre-set callbacks, so they are
    # converted where rclpy keeps them (the attribute every rclpy since Foxy has).
    overrides = getattr(node, '_parameter_overrides', {})
    if name in overrides:
        overrides[name] = as_declared(overrides[name], kinds[name])


def declare(
    node: Node,
    name: str,
    default: Any,
    description: str,
    *,
    low: float | None = None,
    high: float | None = None,
    read_only: bool = False,
) -> Any:
    """Declare a parameter with its description and, for numbers, its allowed range.

    A double (or double array) parameter also takes integers, a string parameter an integer
    (see :func:`as_declared`).
    """
    _accept_other_syntax(node, name, default)
    descriptor = ParameterDescriptor(description=description, read_only=read_only)
    if low is not None and high is not None:
        if isinstance(default, bool):
            pass
        elif isinstance(default, int):
            descriptor.integer_range = [IntegerRange(from_value=int(low), to_value=int(high), step=0)]
        elif isinstance(default, float):
            descriptor.floating_point_range = [
                FloatingPointRange(from_value=float(low), to_value=float(high), step=0.0)
            ]
    return node.declare_parameter(name, default, descriptor).value


# Every stage reduces its frames as the tracker does: one meaning, the tracker's field's.
WORKING_WIDTH_DESCRIPTION = description_of(FrameParameters, 'working_width')


def declare_working_width(node: Node) -> int:
    """The ``working_width`` of a cue stage (see :mod:`human_tracker.vision.cues.resolution`)."""
    return declare(node, 'working_width', 320, WORKING_WIDTH_DESCRIPTION, low=0, high=100000, read_only=True)


def image_qos(node: Node) -> QoSProfile:
    """Image subscription QoS: sensor data (best effort, newest frame) unless overridden.

    Parameters ``qos_reliability`` (``best_effort`` | ``reliable``) and ``qos_depth`` let a
    bag replay that must not lose a frame ask for reliable delivery and a deeper queue.
    """
    reliability = declare(
        node,
        'qos_reliability',
        'best_effort',
        'Image subscription reliability: best_effort or reliable (with a deeper qos_depth: every frame of a replay).',
        read_only=True,
    )
    depth = declare(
        node,
        'qos_depth',
        1,
        'Image subscription queue depth (1: always the newest frame).',
        low=1,
        high=1000,
        read_only=True,
    )
    if reliability not in ('best_effort', 'reliable'):
        raise ValueError(f"qos_reliability must be 'best_effort' or 'reliable', got {reliability!r}")
    profile = QoSProfile(
        depth=int(depth),
        history=HistoryPolicy.KEEP_LAST,
        reliability=ReliabilityPolicy.RELIABLE if reliability == 'reliable' else ReliabilityPolicy.BEST_EFFORT,
        durability=qos_profile_sensor_data.durability,
    )
    return profile


@dataclass
class FrameCounters:
    """Where every input frame went: each one is processed, skipped or rejected.

    ``inactive`` counts the skipped frames that arrived while a managed node was not active.
    ``dropped`` counts the frames the camera's publisher sent that never reached the node: a
    newer frame replaced them in the subscription's queue (``qos_depth``) while the node was
    busy, or they were lost on the way (:class:`PublisherSequence`).
    """

    received: int = 0
    processed: int = 0
    skipped: int = 0
    inactive: int = 0
    rejected: int = 0
    dropped: int = 0
    rejected_reasons: dict[str, int] = field(default_factory=dict)

    def reject(self, reason: str) -> None:
        """Count a frame that could not be used, by reason."""
        self.rejected += 1
        self.rejected_reasons[reason] = self.rejected_reasons.get(reason, 0) + 1

    def as_dict(self) -> dict[str, int]:
        """Counters as a flat dictionary."""
        return {
            'received': self.received,
            'processed': self.processed,
            'skipped': self.skipped,
            'inactive': self.inactive,
            'rejected': self.rejected,
            'dropped': self.dropped,
        }


@dataclass
class PublisherSequence:
    """Frames missed between two that arrived, from the publisher's sequence numbers (DDS numbers
    each writer's samples 1, 2, 3, ...; rclpy gives the number with the message).

    The numbers are one writer's, and a message does not say which writer sent it: with more than
    one publisher matched nothing is counted. A number not above the last one (a new or restarted
    publisher) starts the count again.
    """

    last: int | None = None

    def missed(self, sequence: int | None, publishers: int) -> int:
        """The frames sent between the last one and this one (``sequence``; None: unknown) that
        never arrived, with ``publishers`` publishers matched."""
        if sequence is None or publishers != 1:
            self.last = None
            return 0
        last, self.last = self.last, sequence
        return 0 if last is None or sequence <= last else sequence - last - 1


@dataclass
class StageTimer:
    """Running mean of processing time and input rate over a window of frames."""

    window: int = 30
    durations: list[float] = field(default_factory=list)
    arrivals: list[float] = field(default_factory=list)

    def arrived(self) -> None:
        """Note the arrival time of an input frame."""
        self.arrivals.append(time.monotonic())
        del self.arrivals[: -self.window]

    def took(self, seconds: float) -> None:
        """Note how long one frame took to process."""
        self.durations.append(seconds)
        del self.durations[: -self.window]

    @property
    def mean_ms(self) -> float:
        """Mean processing time, milliseconds."""
        return 1000.0 * sum(self.durations) / len(self.durations) if self.durations else 0.0

    @property
    def rate_hz(self) -> float:
        """Input frame rate, Hz."""
        if len(self.arrivals) < 2 or self.arrivals[-1] == self.arrivals[0]:
            return 0.0
        return (len(self.arrivals) - 1) / (self.arrivals[-1] - self.arrivals[0])


def diagnostic_status(
    node: Node,
    counters: FrameCounters,
    timer: StageTimer,
    *,
    state: str,
    level: bytes | None = None,
    extra: dict[str, Any] | None = None,
) -> DiagnosticStatus:
    """A DiagnosticStatus with the node's frame accounting, timing and state."""
    if level is None:
        level = DiagnosticStatus.OK if state in ('TRACKING', 'OK') else DiagnosticStatus.WARN
    values = {
        'input_rate_hz': f'{timer.rate_hz:.2f}',
        'processing_ms': f'{timer.mean_ms:.2f}',
        **{f'frames_{k}': v for k, v in counters.as_dict().items()},
        **{f'rejected_{k}': v for k, v in counters.rejected_reasons.items()},
        **(extra or {}),
    }
    return node_status(node, state, values, level=level)


def node_status(
    node: Node, state: str, values: dict[str, Any], *, level: bytes | None = None, hardware_id: str = 'camera'
) -> DiagnosticStatus:
    """A DiagnosticStatus named after ``node``: its state word, then ``values`` as text (OK unless told)."""
    return DiagnosticStatus(
        level=DiagnosticStatus.OK if level is None else level,
        name=node.get_fully_qualified_name(),
        message=state,
        hardware_id=hardware_id,
        values=[KeyValue(key=k, value=str(v)) for k, v in {'state': state, **values}.items()],
    )


def publish_diagnostics(node: Node, publisher: Any, statuses: list[DiagnosticStatus]) -> None:
    """Publish statuses on /diagnostics stamped now."""
    array_ = DiagnosticArray(status=statuses)
    array_.header.stamp = node.get_clock().now().to_msg()
    publisher.publish(array_)


def shutdown() -> None:
    """Shut rclpy's default context down if it is still up.

    ``rclpy.try_shutdown`` checks the context and then shuts it down, but on Ctrl-C rclpy's
    signal handler shuts it down from its own thread without taking the same lock: between the
    check and the call the context can go, and the call raises (a node stopped by SIGINT then
    exited with 1 instead of 0, now and then).
    """
    try:
        rclpy.try_shutdown()
    except RuntimeError:  # rclpy's RCLError: rcl_shutdown already called
        if rclpy.ok():
            raise


STOP_POLL_SECONDS = 0.1
"""Seconds a spinning loop waits for work before it looks whether a stop was asked for."""


def init_without_signal_handlers(args: list[str] | None = None) -> None:
    """``rclpy.init`` without rclpy's SIGINT / SIGTERM handlers: :func:`stop_on_signals` stops the nodes.

    rclpy's handlers shut the context down from a thread of their own, whatever the nodes are
    doing at that moment (a callback publishing, a node being destroyed): a pipeline stopped
    with Ctrl-C while it warmed up died, now and then, of a segmentation fault (exit -11).

    Raises:
        StartError: rcl refused the ROS arguments, or a parameter file is missing or not YAML.
    """
    init_rclpy(sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO)


@contextmanager
def stop_on_signals(*, interrupt: bool = False) -> Iterator[threading.Event]:
    """SIGINT and SIGTERM set the event this yields: the nodes stop between two callbacks.

    Args:
        interrupt: The first signal also raises KeyboardInterrupt in the main thread (whose
            work of its own, such as publishing frames while another thread spins, must stop).
            Default False: the main thread spins (:func:`spin_until`) and ends once the callback
            running has returned. A second signal always raises it, so a stop waiting for a long
            callback can be forced.

    The previous handlers are put back on exit. Outside the main thread, where Python cannot
    handle signals, nothing is installed and the event is only set by the caller.
    """
    stop = threading.Event()

    def on_signal(signum: int, frame: object) -> None:
        if interrupt or stop.is_set():
            stop.set()
            raise KeyboardInterrupt
        stop.set()

    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = {number: signal.signal(number, on_signal) for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def spin_until(executor: Executor, stop: threading.Event) -> None:
    """Run ``executor``'s callbacks until ``stop`` is set (seen within :data:`STOP_POLL_SECONDS`)."""
    while not stop.is_set():
        executor.spin_once(timeout_sec=STOP_POLL_SECONDS)
