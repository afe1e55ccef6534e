"""Helpers for tests that run nodes as separate processes over real DDS."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import rclpy
from rclpy.executors import SingleThreadedExecutor

from human_tracker.ros.collector import PoseCollector
from human_tracker.ros.processes import NodeProcess, ros_environment


def run_bag_play(*arguments: str) -> subprocess.CompletedProcess:
    """``bag_play`` with ``arguments`` in this test process's DDS domain, run to its end."""
    return subprocess.run(
        [sys.executable, '-m', 'human_tracker.ros.bag_play', *arguments],
        capture_output=True,
        text=True,
        timeout=120,
        env=environment(),
    )


def environment() -> dict[str, str]:
    """This test process's private DDS domain (set in conftest)."""
    return ros_environment(int(os.environ['ROS_DOMAIN_ID']))


@contextmanager
def collecting(
    *, markers: bool = False, standard: bool = False
) -> Iterator[tuple[PoseCollector, SingleThreadedExecutor]]:
    """rclpy up, a PoseCollector spun by its own executor (with ``markers``, ``standard``: those
    too); everything torn down after."""
    rclpy.init()
    collector = PoseCollector(markers=markers, standard=standard)
    executor = SingleThreadedExecutor()
    executor.add_node(collector)
    try:
        yield collector, executor
    finally:
        executor.shutdown()
        collector.destroy_node()
        rclpy.try_shutdown()


def replay_and_collect(
    nodes: NodeProcess | list[NodeProcess],
    bag: Path,
    camera_topic: str,
    tmp: Path,
    expected: int,
    rate: float = 2.0,
    diagnostics_of: str = '',
    markers: bool = False,
    standard: bool = False,
) -> PoseCollector:
    """Start ``nodes``, replay ``bag`` into them, return what was published (all frames or 20 s).

    Every node must subscribe to the camera topic; the replay starts when each has said it
    is ready. With ``standard``, the standard outputs are collected too (TF, REP-155,
    vision_msgs). With ``diagnostics_of``, ``expected`` is the
    number of frames that node must report processed in /diagnostics (instead of poses). With
    ``markers``, the RViz markers are collected too (and awaited as the poses are).
    """
    nodes = nodes if isinstance(nodes, list) else [nodes]
    ready = [node.ready_node for node in nodes if node.ready_node]
    player = NodeProcess(
        'human_tracker.ros.bag_play',
        [
            str(bag),
            '--rate',
            str(rate),
            '--wait-for-subscribers',
            camera_topic,
            str(len(nodes)),
            '--wait-for-ready',
            *ready,
        ],
        environment(),
        tmp / 'bag_play.log',
    )
    with collecting(markers=markers, standard=standard) as (collector, executor):
        try:
            for node in nodes:
                node.start()
            assert collector.wait_for_publisher(executor, 60.0), '\n'.join(node.output() for node in nodes)
            player.start()
            deadline = time.monotonic() + 60.0
            while player.process.poll() is None and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            assert player.wait(10.0) == 0, player.output()
            deadline = time.monotonic() + 20.0
            while time.monotonic() < deadline:
                if diagnostics_of:
                    done = collector.diagnostics.get(diagnostics_of, {}).get('frames_processed') == str(expected)
                else:
                    done = len(collector.poses) >= expected and (not markers or len(collector.markers) >= expected)
                if done:
                    break
                executor.spin_once(timeout_sec=0.05)
            # The last frames' other messages (velocity, contour, standard outputs) are sent just
            # after their pose, and another topic (the diagnostics) may arrive before them: taken
            # too before the nodes stop, until nothing has come for half a second (a busy
            # machine's collector lags; at most 5 s).
            drained, quiet_since, count = time.monotonic() + 5.0, time.monotonic(), collector.received()
            while time.monotonic() < drained and time.monotonic() - quiet_since < 0.5:
                executor.spin_once(timeout_sec=0.02)
                if collector.received() != count:
                    quiet_since, count = time.monotonic(), collector.received()
            if diagnostics_of:
                collector.spin_until_diagnostics(executor, diagnostics_of, 5.0)
        finally:
            codes = [node.stop() for node in nodes]
            player.stop()
    for node, code in zip(nodes, codes, strict=True):
        assert code == 0, f'{node.command} exited with {code}:\n{node.output()}'
    return collector
