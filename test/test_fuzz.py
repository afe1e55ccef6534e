"""Randomly malformed images through conversion and the tracker node: nothing escapes, all counted."""

from __future__ import annotations

import array

import cv2
import numpy as np
import rclpy
from rclpy.serialization import serialize_message
from sensor_msgs.msg import CompressedImage, Image

from human_tracker.ros.image_conversion import ENCODINGS, ImageConversionError, message_to_bgr8
from human_tracker.ros.tracker_node import TrackerNode

MESSAGES = 10_000
_ENCODINGS = [*ENCODINGS, 'mono12', '', 'BGR8', 'rgb16', '8UC4', 'jpeg']


def _random_image(rng: np.random.Generator, index: int) -> Image | CompressedImage:
    msg: Image | CompressedImage
    if rng.random() < 0.25:
        good = cv2.imencode(rng.choice(['.jpg', '.png']), rng.integers(0, 255, (16, 16, 3), dtype=np.uint8))[
            1
        ].tobytes()
        kind = rng.integers(0, 4)
        data = [good, good[: rng.integers(0, len(good))], rng.bytes(int(rng.integers(0, 400))), b''][kind]
        msg = CompressedImage(
            format=str(rng.choice(['jpeg', 'png', 'rgb8; jpeg compressed bgr8', 'magic'])), data=array.array('B', data)
        )
    else:
        width = int(rng.choice([0, 1, 2, 3, 17, 32, 64, -1 % 2**32, 70000]))
        height = int(rng.choice([0, 1, 2, 5, 24, 48, 100000]))
        encoding = str(rng.choice(_ENCODINGS))
        layout = ENCODINGS.get(encoding)
        row = width * (layout.channels * np.dtype(layout.dtype).itemsize if layout else 3)
        step = int(max(0, row + rng.choice([-3, -1, 0, 0, 0, 1, 8])))
        size = step * height if step * height < 200_000 else int(rng.integers(0, 5000))
        size = max(0, size + int(rng.choice([0, 0, 0, -1, -size // 2 - 1, 7])))
        if layout is not None and layout.dtype == 'f4' and rng.random() < 0.5 and size % 4 == 0:
            values = rng.choice([np.nan, np.inf, -np.inf, 1.0], size=size // 4).astype(np.float32)
            data = values.tobytes()
        else:
            data = rng.bytes(size)
        msg = Image(
            height=height % 2**32,
            width=width % 2**32,
            encoding=encoding,
            is_bigendian=int(rng.integers(0, 2)),
            step=step % 2**32,
        )
        msg.data = array.array('B', data)
    msg.header.stamp.sec = 1_000 + index // 3 - (5 if index % 97 == 0 else 0)  # duplicates and backward jumps too
    msg.header.stamp.nanosec = (index % 3) * 1000
    return msg


def test_conversion_raises_only_its_own_error() -> None:
    rng = np.random.default_rng(0)
    outcomes = {'ok': 0, 'rejected': 0}
    for index in range(MESSAGES):
        try:
            image = message_to_bgr8(_random_image(rng, index))
            assert image.dtype == np.uint8 and image.ndim == 3 and image.shape[2] == 3
            outcomes['ok'] += 1
        except ImageConversionError:
            outcomes['rejected'] += 1
    print(f'conversion of {MESSAGES} random messages: {outcomes}')
    assert sum(outcomes.values()) == MESSAGES and outcomes['ok'] > 100 and outcomes['rejected'] > 1000


def test_tracker_node_counts_every_malformed_message() -> None:
    """The messages as the subscription gets them, serialised; after every tenth, a copy cut
    short or random bytes, which cannot be read at all."""
    rng, cuts = np.random.default_rng(1), np.random.default_rng(2)
    rclpy.init()
    node = TrackerNode()
    try:
        for index in range(MESSAGES):
            msg = _random_image(rng, index)
            typename, data = f'sensor_msgs/msg/{type(msg).__name__}', serialize_message(msg)
            node.on_wire_image(typename, data)  # what the subscription calls
            if index % 10 == 0:
                node.on_wire_image(typename, data[: int(cuts.integers(0, len(data)))])
                node.on_wire_image(typename, cuts.bytes(int(cuts.integers(0, 64))))
        counters = node.counters
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    print(f'tracker_node after {MESSAGES} random messages: {counters}, time resets {node.time_resets}')
    assert counters.received == MESSAGES + 2_000
    assert counters.processed + counters.skipped + counters.rejected == counters.received
    assert counters.rejected > 3000 and counters.processed > 100 and counters.skipped > 0


def test_a_stage_outlives_a_failing_frame() -> None:
    """Fault injection: the background model fails on one frame; the node counts it and goes on."""
    from human_tracker.ros.background_node import BackgroundNode
    from human_tracker.ros.image_conversion import array_to_image

    rclpy.init()
    node = BackgroundNode()
    try:
        working = node.model.apply

        def broken(gray: np.ndarray) -> np.ndarray:
            raise RuntimeError('injected fault')

        for index, model in enumerate([working, broken, working]):
            node.model.apply = model
            msg = array_to_image(np.full((8, 8, 3), 10 * index, dtype=np.uint8), 'bgr8')
            msg.header.stamp.sec = index + 1
            node.on_image(msg)
        counters = node.counters
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert (counters.received, counters.processed, counters.rejected) == (3, 2, 1)
    assert counters.rejected_reasons == {'error_RuntimeError': 1}
