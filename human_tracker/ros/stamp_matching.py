"""Frames held until the masks of the same stamp arrive, and the gaps between frames: the
tracker node's input timing.

A tracker fed by other nodes (a motion stage, a skin stage, a depth camera) gets each frame and
each of its masks as separate messages. A frame waits, in order, until every mask with its
stamp has arrived, ``match_timeout`` has passed, or more than ``max_pending`` frames wait; then
it is tracked with what came. Masks of frames already tracked are dropped, and those of frames
this node never received (lost on the way to it) are counted.
"""

from __future__ import annotations

import time
from collections import OrderedDict, deque
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple

import numpy as np
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from human_tracker.ros.image_conversion import ImageConversionError, image_to_array
from human_tracker.ros.stage import stamp_ns
from human_tracker.vision.geometry.depth import depth_image_to_metres

__all__ = ['REMEMBERED_STAMPS', 'FrameGaps', 'HeldFrame', 'MaskInputs', 'MaskMatcher']

REMEMBERED_STAMPS = 1000
"""Frames whose arrival is remembered (33 s at 30 Hz), to tell a frame lost upstream."""


class HeldFrame(NamedTuple):
    """A frame waiting for its masks.

    Attributes:
        stamp: Its stamp, ns.
        arrived: When it arrived (monotonic s).
        header: Its message header.
        evidence: The frame's evidence: its cues measured in process (a pipeline's) and what
            was computed of it while it waited (its working frame).
    """

    stamp: int
    arrived: float
    header: Any
    evidence: Any


class MaskMatcher:
    """The frames held for the masks of ``topics``, at most ``max_pending`` of them.

    Attributes:
        masks: Masks not yet matched, by topic and stamp (at most ``4 * max_pending`` a topic).
        unmatched: Frames tracked without their mask, by topic.
        never_received: Masks of frames this node never received (lost upstream).
        received: The stamps of the last :data:`REMEMBERED_STAMPS` frames that reached the node,
            in order (a dict as an ordered set).
        held: The frames waiting, in order.
    """

    def __init__(self, topics: list[str], max_pending: int) -> None:
        self.topics = topics
        self.max_pending = max_pending
        self.masks: dict[str, OrderedDict[int, np.ndarray]] = {topic: OrderedDict() for topic in topics}
        self.unmatched = dict.fromkeys(topics, 0)
        self.never_received = 0
        self.received: OrderedDict[int, None] = OrderedDict()
        self.held: deque[HeldFrame] = deque()

    def arrived(self, stamp: int) -> None:
        """A frame stamped ``stamp`` reached the node (usable or not)."""
        self.received[stamp] = None
        while len(self.received) > REMEMBERED_STAMPS:
            self.received.popitem(last=False)

    def add_mask(self, topic: str, stamp: int, mask: np.ndarray) -> None:
        """A mask of ``topic`` for the frame stamped ``stamp``."""
        masks = self.masks[topic]
        masks[stamp] = mask
        while len(masks) > 4 * self.max_pending:
            masks.popitem(last=False)

    def has_masks(self, stamp: int) -> bool:
        """Whether every mask of the frame stamped ``stamp`` has arrived."""
        return all(stamp in self.masks[topic] for topic in self.topics)

    def due(self, now: float, timeout: float) -> Iterator[tuple[HeldFrame, dict[str, np.ndarray | None]]]:
        """The held frames to track now, in order, each with its masks (None where one did not
        come within ``timeout`` s of ``now``); stops at the first frame still waiting."""
        while self.held:
            frame = self.held[0]
            waiting = now - frame.arrived < timeout and len(self.held) <= self.max_pending
            if waiting and not self.has_masks(frame.stamp):
                return
            self.held.popleft()
            found = {topic: self.masks[topic].pop(frame.stamp, None) for topic in self.topics}
            for topic, mask in found.items():
                self.unmatched[topic] += mask is None
            yield frame, found

    def forget_tracked(self, last_tracked: int) -> int:
        """Drop the masks of frames up to ``last_tracked`` (ns); returns how many of them belong
        to frames this node never received (also counted in ``never_received``)."""
        lost = set()
        oldest_known = next(iter(self.received), None)
        for masks in self.masks.values():
            for stale in [s for s in masks if s <= last_tracked]:
                del masks[stale]
                # Older than every remembered stamp: unknown, so not counted.
                if stale not in self.received and oldest_known is not None and stale > oldest_known:
                    lost.add(stale)
        self.never_received += len(lost)
        return len(lost)

    def clear(self) -> int:
        """Forget every held frame, mask and stamp (time went backwards); returns the frames dropped."""
        dropped = len(self.held)
        self.held.clear()
        self.received.clear()
        for masks in self.masks.values():
            masks.clear()
        return dropped


# The CPU share of a gap above which this process, not the camera, made it. An idle node uses
# next to nothing; a busy one sharing two cores with three other busy processes still gets half.
STALL_SHARE = 0.25


class FrameGaps:
    """The time between the frames tracked, by their stamps.

    A gap over ``max_gap`` is told apart: the camera paused (this process idled), or this
    process stalled (it was busy for more than :data:`STALL_SHARE` of the gap: the camera's frames
    were dropped meanwhile), counted in ``stalls``. Measured from the start of the last frame
    tracked, so its own processing is included.

    Attributes:
        last_stamp: The stamp of the last frame tracked, ns (-1: none yet).
        stalls: Gaps of this process's own making.
    """

    def __init__(self) -> None:
        self.last_stamp = -1
        self.stalls = 0
        self._started = (time.monotonic(), time.process_time())  # the last frame's start: wall, CPU

    def next(self, stamp: int, max_gap: float) -> tuple[float, str | None]:
        """Seconds since the frame before the one stamped ``stamp`` (0 for the first), and why a
        gap over ``max_gap`` s happened (None: no such gap)."""
        interval = (stamp - self.last_stamp) / 1e9 if self.last_stamp >= 0 else 0.0
        wall, cpu = time.monotonic(), time.process_time()
        cause = None
        if interval > max_gap:
            busy = (cpu - self._started[1]) / max(wall - self._started[0], 1e-6)
            if busy > STALL_SHARE:
                self.stalls += 1
                cause = f'this node was busy for {interval:.2f} s (its own stall: frames were dropped meanwhile)'
            else:
                cause = f'{interval:.2f} s since the last frame (the camera paused, or frames were lost)'
        self._started = (wall, cpu)
        self.last_stamp = stamp
        return interval, cause


class MaskInputs:
    """A tracker node's mask topics, subscribed, each frame held until its masks arrive.

    ``track(frame, masks)`` is called for each frame due, in order, with its masks by topic
    (None where one did not come within the node's ``match_timeout``). A ``depth`` topic takes
    16UC1 (mm) or 32FC1 (m) images, converted to metres; other masks take their first channel.
    """

    def __init__(
        self,
        node: Any,
        topics: list[str],
        max_pending: int,
        track: Callable[[HeldFrame, dict[str, np.ndarray | None]], None],
    ) -> None:
        self.node = node
        self.track = track
        self.matcher = MaskMatcher(topics, max_pending)
        # Masks queue as deep as the frames that may wait for them, so none is dropped.
        qos = QoSProfile(depth=4 * max_pending, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
        self.subscriptions = [
            node.create_subscription(Image, topic, lambda msg, topic=topic: self.on_mask(topic, msg), qos)
            for topic in topics
        ]
        if topics:
            node.create_timer(0.02, self.drain, clock=node.steady_clock)

    def unconnected(self) -> list[str]:
        """The mask topics no publisher is matched on yet: their first masks would be lost."""
        return [sub.topic_name for sub in self.subscriptions if sub.get_publisher_count() == 0]

    def on_mask(self, topic: str, msg: Image) -> None:
        """A mask message of ``topic``: converted, matched, and any frame now due tracked."""
        node = self.node
        try:
            mask = image_to_array(msg)
        except ImageConversionError as err:
            node.get_logger().warn(f'{topic} mask rejected: {err}', throttle_duration_sec=5.0)
            return
        if topic == 'depth':
            if mask.ndim != 2 or mask.dtype not in (np.uint16, np.float32):
                node.counters.reject('depth_encoding')
                node.get_logger().warn(
                    f'depth image rejected: {msg.encoding}, not 16UC1 (mm) or 32FC1 (m)', throttle_duration_sec=5.0
                )
                return
            mask = depth_image_to_metres(mask)
        self.matcher.add_mask(topic, stamp_ns(msg.header), mask if mask.ndim == 2 else mask[..., 0])
        self.drain()

    def hold(self, frame: HeldFrame) -> None:
        """Hold ``frame`` for its masks (tracked at once if they are all here)."""
        self.matcher.held.append(frame)
        self.drain()

    def drain(self) -> None:
        """Track held frames in order, each with its masks, or without those that waited too long."""
        node = self.node
        timeout = node.get_parameter('match_timeout').value
        for frame, found in self.matcher.due(time.monotonic(), timeout):
            for topic in (t for t, mask in found.items() if mask is None):
                node.get_logger().warn(
                    f'frame tracked without its {topic} mask (none within {timeout} s)', throttle_duration_sec=5.0
                )
            self.track(frame, found)
        lost = self.matcher.forget_tracked(node.gaps.last_stamp)
        if lost:
            node.get_logger().warn(
                f'{lost} frame(s) reached a cue stage but never this node (lost upstream)', throttle_duration_sec=5.0
            )
