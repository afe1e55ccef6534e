"""Helpers for tests that run nodes as separate processes over real DDS."""

from __future__ import annotations

import os
import time
from pathlib import Path

import rclpy
from rclpy.executors import SingleThreadedExecutor

from human_tracker.ros.collector import PoseCollector
from human_tracker.ros.processes import NodeProcess, ros_environment


def environment() -> dict[str, str]:
    """This test process's private DDS domain (set in conftest)."""
    return ros_environment(int(os.environ['ROS_DOMAIN_ID']))


def replay_and_collect(
    node: NodeProcess, bag: Path, camera_topic: str, tmp: Path, expected: int, rate: float = 2.0
) -> PoseCollector:
    """Start ``node``, replay ``bag`` into it, and return what it published (all frames or 20 s)."""
    env = environment()
    rclpy.init()
    collector = PoseCollector()
    executor = SingleThreadedExecutor()
    executor.add_node(collector)
    player = NodeProcess(
        'human_tracker.ros.bag_play',
        [str(bag), '--rate', str(rate), '--wait-for-subscribers', camera_topic, '1'],
        env,
        tmp / 'bag_play.log',
    )
    try:
        node.start()
        assert collector.wait_for_publisher(executor, 60.0), node.output()
        player.start()
        deadline = time.monotonic() + 60.0
        while player.process.poll() is None and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        assert player.wait(10.0) == 0, player.output()
        deadline = time.monotonic() + 20.0
        while len(collector.poses) < expected and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
    finally:
        code = node.stop()
        player.stop()
        executor.shutdown()
        collector.destroy_node()
        rclpy.try_shutdown()
    assert code == 0, f'node exited with {code}:\n{node.output()}'
    return collector
