"""``pipeline``: every stage in one process, frames handed over in memory.

A camera subscriber converts each image once and passes the array to the stages (today
the tracker), so no frame is serialised twice; the stages publish the same topics as the
separate nodes, under the same parameters.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import numpy as np
import rclpy
import rclpy.logging
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import CompressedImage, Image

from human_tracker.ros.common import FrameCounters, declare, image_qos
from human_tracker.ros.image_conversion import ImageConversionError, message_to_bgr8
from human_tracker.ros.tracker_node import TrackerNode

__all__ = ['CameraSubscriber', 'main']

FrameConsumer = Callable[[np.ndarray, Any], object]


class CameraSubscriber(Node):
    """Subscribes ``image`` (or ``image/compressed``) and hands each BGR frame to consumers."""

    def __init__(self, consumers: list[FrameConsumer], **kwargs: Any) -> None:
        super().__init__('camera_subscriber', **kwargs)
        self.consumers = consumers
        self.counters = FrameCounters()
        transport = declare(
            self, 'image_transport', 'raw', 'Image input: raw (image) or compressed (image/compressed).', read_only=True
        )
        if transport not in ('raw', 'compressed'):
            raise ValueError(f"image_transport must be 'raw' or 'compressed', got {transport!r}")
        qos = image_qos(self)
        if transport == 'compressed':
            self.create_subscription(CompressedImage, 'image/compressed', self.on_image, qos)
        else:
            self.create_subscription(Image, 'image', self.on_image, qos)

    def on_image(self, msg: Image | CompressedImage) -> None:
        """Convert once; a frame that cannot be converted is counted and logged."""
        self.counters.received += 1
        try:
            image = message_to_bgr8(msg)
        except ImageConversionError as err:
            self.counters.reject('conversion')
            self.get_logger().warn(f'frame rejected: {err}', throttle_duration_sec=5.0)
            return
        self.counters.processed += 1
        for consume in self.consumers:
            consume(image, msg.header)


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker pipeline``; returns the exit code."""
    rclpy.init(args=args)
    nodes: list[Node] = []
    executor = SingleThreadedExecutor()
    code = 0
    try:
        tracker = TrackerNode(subscribe_image=False)
        camera = CameraSubscriber([tracker.handle_frame])
        nodes = [tracker, camera]
        for node in nodes:
            executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ValueError as err:
        rclpy.logging.get_logger('pipeline').error(f'cannot start: {err}')
        code = 2
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())
