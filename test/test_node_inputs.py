"""Every listed image encoding, and compressed images, through a node over real DDS."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np
import rclpy
from conftest import BAGS
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CompressedImage, Image

from human_tracker.drawing import id_colour
from human_tracker.io.bags import read_frames
from human_tracker.ros.background_node import BackgroundNode
from human_tracker.ros.common import PublisherSequence, diagnostic_status
from human_tracker.ros.image_conversion import ENCODINGS, array_to_compressed, array_to_image, message_to_bgr8
from human_tracker.ros.pipeline import CameraSubscriber, build_pipeline
from human_tracker.ros.tracker_node import TrackerNode
from human_tracker.vision.cues.skin import SkinSegmenter, default_skin_model

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
IMAGE_ENCODINGS = sorted(e for e in ENCODINGS if e != '32FC2')  # 32FC2 is flow, not a picture


def _pixels(encoding: str, rng: np.random.Generator) -> np.ndarray:
    layout = ENCODINGS[encoding]
    shape = (48, 64) if layout.channels == 1 else (48, 64, layout.channels)
    if layout.dtype == 'f4':
        return rng.uniform(0.5, 4.0, size=shape).astype(np.float32)
    return rng.integers(0, np.iinfo(np.dtype(layout.dtype)).max, size=shape, dtype=np.dtype(layout.dtype))


def _run(transport: str, messages: list) -> tuple[list[int], BackgroundNode]:
    """Publish ``messages`` to a background_node in this process; return the foreground stamps."""
    rclpy.init()
    overrides = [
        Parameter('image_transport', value=transport),
        Parameter('qos_reliability', value='reliable'),
        Parameter('qos_depth', value=100),
    ]
    stage = BackgroundNode(parameter_overrides=overrides)
    source = Node('camera')
    topic = 'image/compressed' if transport == 'compressed' else 'image'
    publisher = source.create_publisher(CompressedImage if transport == 'compressed' else Image, topic, RELIABLE)
    stamps: list[int] = []
    source.create_subscription(Image, 'foreground', lambda m: stamps.append(m.header.stamp.sec), RELIABLE)
    executor = SingleThreadedExecutor()
    executor.add_node(stage)
    executor.add_node(source)
    try:
        deadline = time.monotonic() + 20.0
        while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        for msg in messages:
            publisher.publish(msg)
        deadline = time.monotonic() + 20.0
        while stage.counters.received < len(messages) and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        for _ in range(20):
            executor.spin_once(timeout_sec=0.02)
    finally:
        executor.shutdown()
        stage.destroy_node()
        source.destroy_node()
        rclpy.try_shutdown()
    return stamps, stage


def test_every_listed_encoding_is_processed_and_a_bad_one_is_counted() -> None:
    rng = np.random.default_rng(0)
    messages = []
    for index, encoding in enumerate(IMAGE_ENCODINGS, start=1):
        msg = array_to_image(_pixels(encoding, rng), encoding)
        msg.header.stamp.sec = index
        messages.append(msg)
    bad = array_to_image(_pixels('mono8', rng), 'mono8')
    bad.encoding = 'mono12'  # not a ROS encoding
    bad.header.stamp.sec = 1000
    stamps, stage = _run('raw', [*messages, bad])
    print(f'encodings through background_node: {IMAGE_ENCODINGS}; counters {stage.counters}')
    assert stamps == list(range(1, len(IMAGE_ENCODINGS) + 1))  # one foreground per frame, in order
    assert stage.counters.processed == len(IMAGE_ENCODINGS)
    assert stage.counters.rejected == 1 and stage.counters.rejected_reasons == {'conversion': 1}
    assert stage.counters.dropped == 0  # reliable, a queue as deep as the frames sent


def test_compressed_jpeg_and_png_input() -> None:
    rng = np.random.default_rng(1)
    messages = []
    for index, kind in enumerate(['jpeg', 'png', 'jpeg'], start=1):
        msg = array_to_compressed(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8), kind)
        msg.header.stamp.sec = index
        messages.append(msg)
    stamps, stage = _run('compressed', messages)
    assert stamps == [1, 2, 3]
    assert stage.counters.rejected == 0


@contextmanager
def _tracker_and_camera(overrides: list[Parameter]) -> Iterator[tuple[TrackerNode, Node, SingleThreadedExecutor]]:
    """rclpy up, a tracker node with ``overrides`` and a ``camera`` node spun by one executor;
    everything torn down after."""
    rclpy.init()
    tracker = TrackerNode(parameter_overrides=overrides)
    source = Node('camera')
    executor = SingleThreadedExecutor()
    executor.add_node(tracker)
    executor.add_node(source)
    try:
        yield tracker, source, executor
    finally:
        executor.shutdown()
        tracker.destroy_node()
        source.destroy_node()
        rclpy.try_shutdown()


def _spin_until(executor: SingleThreadedExecutor, done: Callable[[], bool], timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not done() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)


def test_tracker_debug_image_and_pose_carry_the_input_header() -> None:
    frames = list(read_frames(str(BAGS / 'head_basic')))[:3]
    box = [float(v) for v in frames[0].ground_truth]
    overrides = [
        Parameter('init_box', value=box),
        Parameter('qos_reliability', value='reliable'),
        Parameter('qos_depth', value=10),
    ]
    with _tracker_and_camera(overrides) as (tracker, source, executor):
        publisher = source.create_publisher(Image, 'image', RELIABLE)
        debug: list[Image] = []
        poses: list = []
        source.create_subscription(Image, 'debug_image', debug.append, RELIABLE)
        source.create_subscription(PoseWithCovarianceStamped, 'pose', poses.append, RELIABLE)
        _spin_until(
            executor,
            lambda: publisher.get_subscription_count() >= 1 and tracker.outputs.debug_pub.get_subscription_count() >= 1,
        )
        sent = []
        for frame in frames:
            msg = array_to_image(message_to_bgr8(frame.message), 'bgr8')
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(frame.stamp_ns, 10**9)
            msg.header.frame_id = 'camera_optical_frame'
            publisher.publish(msg)
            sent.append(msg.header)
        _spin_until(executor, lambda: min(len(debug), len(poses)) >= len(frames))
    assert [m.header for m in debug] == sent
    assert [p.header for p in poses] == sent
    assert all(m.encoding == 'bgr8' and (m.width, m.height) == (640, 480) for m in debug)


def test_a_person_debug_image_draws_each_target_in_its_id_colour() -> None:
    """target person: the hand, once it has an id, is drawn in that id's colour on debug_image."""
    frames = list(read_frames(str(BAGS / 'hand_wave')))[:40]
    overrides = [
        Parameter('target', value='person'),
        Parameter('skin_input', value=True),
        Parameter('qos_reliability', value='reliable'),
        Parameter('qos_depth', value=50),
    ]
    with _tracker_and_camera(overrides) as (tracker, source, executor):
        publisher = source.create_publisher(Image, 'image', RELIABLE)
        skin_publisher = source.create_publisher(Image, 'skin', RELIABLE)
        segmenter = SkinSegmenter(default_skin_model())
        debug: list[Image] = []
        source.create_subscription(Image, 'debug_image', debug.append, RELIABLE)
        _spin_until(
            executor,
            lambda: (
                skin_publisher.get_subscription_count() >= 1 and tracker.outputs.debug_pub.get_subscription_count() >= 1
            ),
        )
        for frame in frames:
            image = message_to_bgr8(frame.message)
            for topic, msg in (
                (skin_publisher, array_to_image(segmenter.segment(image), 'mono8')),
                (publisher, array_to_image(image, 'bgr8')),
            ):
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(frame.stamp_ns, 10**9)
                topic.publish(msg)
        _spin_until(executor, lambda: len(debug) >= len(frames), timeout=30.0)
        hand = next(o for o in tracker.last_outcomes if o.kind == 'hand')
    assert len(debug) == len(frames) and hand.id > 0 and hand.result.tracking
    shown = message_to_bgr8(debug[-1])
    x, y, w, h = (int(round(v)) for v in hand.result.estimate.box)
    side = shown[y + h // 4 : y + h, x]  # the box's left side, below its tag
    print(f'hand {hand.id}, box {hand.result.estimate.box}: left side {side[::8].tolist()}')
    drawn = np.abs(side.astype(np.int64) - id_colour(hand.id)).max(axis=1) <= 40  # anti-aliased
    assert drawn.mean() > 0.9


def test_frames_the_node_never_received_are_counted_as_dropped() -> None:
    """Sensor-data QoS keeps the newest frame: frames published while the node is busy are
    replaced in its queue of one. Each is counted (``frames_dropped``) from the gaps in the
    publisher's sequence numbers, so received + dropped = sent."""
    rclpy.init()
    stage = BackgroundNode()  # best effort, depth 1: a robot's default
    source = Node('camera')
    publisher = source.create_publisher(Image, 'image', QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    executor = SingleThreadedExecutor()
    executor.add_node(stage)
    executor.add_node(source)
    rng = np.random.default_rng(2)
    frames = [array_to_image(rng.integers(0, 255, (48, 64), dtype=np.uint8), 'mono8') for _ in range(32)]
    for index, msg in enumerate(frames, start=1):
        msg.header.stamp.sec = index

    def spin_until_received(count: int) -> None:
        deadline = time.monotonic() + 20.0
        while stage.counters.received < count and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)

    try:
        deadline = time.monotonic() + 20.0
        while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        spin_until_received(0)
        publisher.publish(frames[0])
        spin_until_received(1)
        for msg in frames[1:-1]:  # the node does not spin meanwhile: a busy node
            publisher.publish(msg)
            time.sleep(0.002)
        spin_until_received(2)
        for _ in range(10):
            executor.spin_once(timeout_sec=0.02)
        publisher.publish(frames[-1])  # the last one shows how many came before it
        spin_until_received(stage.counters.received + 1)
    finally:
        executor.shutdown()
        stage.destroy_node()
        source.destroy_node()
        rclpy.try_shutdown()
    counters = stage.counters
    print(f'{len(frames)} sent: {counters}')
    assert counters.dropped > 0
    assert counters.received + counters.dropped == len(frames)


def test_a_gap_in_one_publishers_sequence_numbers_counts_the_frames_missed() -> None:
    """Gaps count while one publisher is matched; a number not above the last (a restarted
    publisher), two publishers or no number start the count again without counting."""
    sequence = PublisherSequence()
    assert [sequence.missed(n, 1) for n in (1, 2, 5, 6)] == [0, 0, 2, 0]
    assert sequence.missed(1, 1) == 0 and sequence.missed(4, 1) == 2  # restarted, then a gap
    assert sequence.missed(9, 2) == 0 and sequence.missed(20, 1) == 0  # two publishers: unknown
    assert sequence.missed(None, 1) == 0 and sequence.missed(30, 1) == 0


def test_the_pipelines_tracker_counts_every_frame_it_never_processed() -> None:
    """In ``pipeline`` the camera subscriber takes the frames: a frame it could not read, a
    duplicate it skipped and the frames a newer one replaced in its queue never reach the
    tracker, whose ``frames_dropped`` counts them all: received + dropped = sent."""
    rclpy.init()
    nodes = build_pipeline()
    camera = next(node for node in nodes if isinstance(node, CameraSubscriber))
    tracker = next(node for node in nodes if isinstance(node, TrackerNode))
    source = Node('camera')
    publisher = source.create_publisher(Image, 'image', QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    executor = SingleThreadedExecutor()
    for node in (*nodes, source):
        executor.add_node(node)
    rng = np.random.default_rng(3)
    frames = [array_to_image(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8), 'bgr8') for _ in range(24)]
    for index, msg in enumerate(frames, start=1):
        msg.header.stamp.sec = index
    frames[1].data = frames[1].data[:100]  # cannot be read: rejected by the camera subscriber
    frames[2].header.stamp.sec = frames[1].header.stamp.sec - 1  # the first frame's stamp: a duplicate

    def publish_and_wait(msg: Image) -> None:
        received = camera.counters.received
        publisher.publish(msg)
        deadline = time.monotonic() + 20.0
        while camera.counters.received == received and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)

    try:
        deadline = time.monotonic() + 20.0
        while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        for msg in frames[:3]:
            publish_and_wait(msg)
        for msg in frames[3:-1]:  # nothing spins meanwhile: a busy pipeline
            publisher.publish(msg)
            time.sleep(0.002)
        for _ in range(20):
            executor.spin_once(timeout_sec=0.02)
        publish_and_wait(frames[-1])  # the last one shows how many came before it
        status = diagnostic_status(tracker, tracker.counters, tracker.timer_stats, state='OK')
        diagnostics = {kv.key: kv.value for kv in status.values}
    finally:
        executor.shutdown()
        for node in (*nodes, source):
            node.destroy_node()
        rclpy.try_shutdown()
    seen, passed = camera.counters, tracker.counters
    print(f'{len(frames)} sent: camera subscriber {seen}; tracker {passed}')
    assert seen.rejected == 1 and seen.skipped == 1 and seen.dropped > 0
    assert seen.received + seen.dropped == len(frames)
    assert passed.received == seen.processed and passed.dropped == seen.dropped + 2
    assert passed.received + passed.dropped == len(frames)
    assert int(diagnostics['frames_dropped']) == passed.dropped
