"""Latency over DDS: a camera simulator publishes raw frames of a bag to the package's nodes (OS
processes), in the ``pipeline`` and the ``separate`` layouts, at 30 Hz and at full speed, alone
and beside busy processes; and the thread policy's effect on a tracker beside them.

Latency is pose arrival time minus image stamp (``make bench``, :mod:`human_tracker.bench`).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from human_tracker.io.images import stamp_ns
from human_tracker.ros.collector import PoseCollector
from human_tracker.ros.processes import NodeProcess

__all__ = ['busy_processes', 'measure_latency', 'thread_policy']

_RESULTS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


class _Camera(Node):
    """Publishes frames stamped now and records when each pose comes back."""

    def __init__(self) -> None:
        super().__init__('bench_camera')
        self.publisher = self.create_publisher(
            Image, 'image', QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
        )
        self.sent: dict[int, float] = {}
        self.latency_s: dict[int, float] = {}
        self.create_subscription(PoseWithCovarianceStamped, 'pose', self._on_pose, _RESULTS)

    def send(self, message: Image) -> int:
        now = self.get_clock().now()
        message.header.stamp = now.to_msg()
        stamp = now.nanoseconds
        self.sent[stamp] = time.monotonic()
        self.publisher.publish(message)
        return stamp

    def _on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        stamp = stamp_ns(msg.header)
        if stamp in self.sent:
            self.latency_s[stamp] = time.monotonic() - self.sent[stamp]


def _layout(name: str, box: list[float], env: dict[str, str], logs: Path) -> list[NodeProcess]:
    init = ['-p', 'init_box:=[' + ', '.join(f'{v:.1f}' for v in box) + ']']
    if name == 'pipeline':
        return [
            NodeProcess(
                'human_tracker.ros.pipeline',
                ['--ros-args', '-p', 'motion_cue:=background', *init],
                env,
                logs / 'pipeline.log',
            )
        ]
    return [
        NodeProcess('human_tracker.ros.background_node', ['--ros-args'], env, logs / 'background_node.log'),
        NodeProcess(
            'human_tracker.ros.tracker_node',
            ['--ros-args', '-p', 'motion_input:=foreground', *init],
            env,
            logs / 'tracker_node.log',
        ),
    ]


def _handshake(camera: _Camera, executor: SingleThreadedExecutor, first: Image, deadline: float) -> None:
    """Send ``first`` until its pose comes back, then forget it: the box is given for the first
    frame, and a node whose subscription has matched may still miss the first frames sent (one
    run's tracker received 216 of 240, started its box on a later frame than the box's, and
    returned 48 poses). It is sent again only after 3 s, longer than the tracker's ``max_gap``
    (1 s)."""
    while True:
        stamp = camera.send(first)
        # A frame the tracker did take, re-sent sooner but reaching it after max_gap (beside
        # busy processes), would mark its target lost; on one frame sent again and again no
        # motion brings it back.
        wait_until = time.monotonic() + 3.0
        while stamp not in camera.latency_s and time.monotonic() < wait_until:
            executor.spin_once(timeout_sec=0.01)
        if stamp in camera.latency_s:
            break
        if time.monotonic() > deadline:
            raise RuntimeError('no pose came back for the first frame')
    camera.sent.clear()
    camera.latency_s.clear()


def measure_latency(
    layout: str, rate_hz: float | None, frames: list[Image], box: list[float], logs: Path, env: dict[str, str]
) -> dict[str, object]:
    """Run one layout at ``rate_hz`` (None: full speed, closed loop) over ``frames``; nodes get ``env``."""
    nodes = _layout(layout, box, env, logs)
    camera = _Camera()
    collector: PoseCollector | None = None
    executor = SingleThreadedExecutor()
    executor.add_node(camera)
    try:
        for node in nodes:
            node.start()
        deadline = time.monotonic() + 60.0
        subscribers = len(nodes) if layout == 'separate' else 1
        while (
            camera.publisher.get_subscription_count() < subscribers
            or camera.count_publishers(camera.resolve_topic_name('pose')) < 1
        ):
            if time.monotonic() > deadline:
                raise RuntimeError('nodes did not come up:\n' + '\n'.join(node.output() for node in nodes))
            executor.spin_once(timeout_sec=0.05)
        time.sleep(1.0)  # let the nodes finish starting (discovery of their own topics)
        _handshake(camera, executor, frames[0], deadline)
        started = time.monotonic()
        for message in frames:
            stamp = camera.send(message)
            if rate_hz is None:
                wait_until = time.monotonic() + 1.0
                while stamp not in camera.latency_s and time.monotonic() < wait_until:
                    executor.spin_once(timeout_sec=0.001)
            else:
                due = started + len(camera.sent) / rate_hz
                while time.monotonic() < due:
                    executor.spin_once(timeout_sec=max(0.0, min(0.005, due - time.monotonic())))
        elapsed = time.monotonic() - started
        settle = time.monotonic() + 2.0
        while time.monotonic() < settle:
            executor.spin_once(timeout_sec=0.01)
        # The nodes' own account of the frames (where a missing pose went, their processing
        # time), read once the frames are sent: its node, waited on beside the camera's, would
        # delay every pose's arrival.
        collector = PoseCollector(namespace='bench')
        executor.add_node(collector)
        diagnostics = collector.spin_until_diagnostics(executor, '/tracker_node', 5.0)
        # The frame's path: one node runs every stage in turn, or the mask's stage then the tracker.
        chain = ['/camera_subscriber'] if layout == 'pipeline' else ['/background_node', '/tracker_node']
        stages = [collector.spin_until_diagnostics(executor, name, 5.0) for name in chain]
        processing = sum(float(values.get('processing_ms', 'nan')) for values in stages)
    finally:
        for node in nodes:
            node.stop()
        executor.shutdown()
        camera.destroy_node()
        if collector is not None:
            collector.destroy_node()
    latencies = np.array(sorted(camera.latency_s.values())) * 1000.0
    median = float(np.median(latencies)) if latencies.size else float('nan')
    return {
        'layout': layout,
        'rate': 'full speed' if rate_hz is None else f'{rate_hz:g} Hz',
        'frames_sent': len(frames),
        'poses_received': int(latencies.size),
        'throughput_hz': round(latencies.size / elapsed, 2),
        'latency_ms_median': round(float(np.median(latencies)), 2) if latencies.size else None,
        'latency_ms_p95': round(float(np.percentile(latencies, 95)), 2) if latencies.size else None,
        'processing_ms': round(processing, 2),
        'above_processing_ms': round(median - processing, 2),
        'executor': 'SingleThreadedExecutor',
        # Frames the camera sent that never reached the first node (replaced in its queue of one).
        'frames_dropped': stages[0].get('frames_dropped', '-'),
        'tracker_frames_received': diagnostics.get('frames_received', '-'),
        'tracker_frames_without_mask': diagnostics.get('frames_without_foreground', '-'),
        'tracker_frames_never_received': diagnostics.get('frames_never_received', '-'),
    }


@contextmanager
def busy_processes(count: int) -> Iterator[None]:
    """``count`` CPU-bound Python processes running meanwhile, as other nodes on a robot's computer would be."""
    busy = [subprocess.Popen([sys.executable, '-c', 'while True: pass']) for _ in range(count)]
    try:
        yield
    finally:
        for process in busy:
            process.kill()
            process.wait()


def thread_policy(sequence: Path, init: str | None, out: Path, runs: int = 3) -> list[dict[str, object]]:
    """Offline frames per second with 1 thread and with every core, alone and beside two busy processes.

    Each run is a fresh ``human_tracker track`` process (numba's cache warm); the busy
    processes are :func:`busy_processes`.
    """
    rows = []
    for load in (0, 2):
        with busy_processes(load):
            for threads in (1, 0):
                fps = []
                for run in range(runs):
                    folder = out / f'threads_{threads}_load_{load}_{run}'
                    command = [sys.executable, '-m', 'human_tracker.cli', 'track', str(sequence), '--threads']
                    command += [str(threads), '--no-video', '--quiet', '--out', str(folder)]
                    command += ['--init', init] if init else []
                    subprocess.run(command, check=True, capture_output=True)
                    fps.append(float(json.loads((folder / 'summary.json').read_text())['fps']))
                rows.append(
                    {
                        'sequence': sequence.name,
                        'busy_processes': load,
                        'threads': 'every core' if threads == 0 else threads,
                        'fps_median': round(float(np.median(fps)), 1),
                        'fps_min': round(min(fps), 1),
                        'fps_max': round(max(fps), 1),
                    }
                )
                print(json.dumps(rows[-1]))
    return rows
