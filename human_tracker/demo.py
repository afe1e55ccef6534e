"""``make demo``: replay a bag through the tracker over real DDS and report what it did.

Four OS processes on an isolated local DDS domain, as on a robot: ``bag_play`` publishes
the bag, ``background_node`` segments the moving person, ``tracker_node`` tracks with that
foreground as its motion cue (eqs. 3-4), and this process collects the poses. Writes to the output
folder: ``tracking.mp4`` (annotated video), ``poses.csv`` and ``summary.json`` (frames, how
the tracker started, each node's processing ms per frame, the latency from frame to pose,
precision at 20 px against the bag's ground truth). It fails (exit 1, one line saying why)
when a pose is missing or the precision is below what the bag allows.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CompressedImage, Image

from human_tracker.drawing import annotate
from human_tracker.evaluation.metrics import summarise
from human_tracker.io.bags import CAMERA_INFO_TOPIC, read_frames
from human_tracker.io.poses import POSE_COLUMNS
from human_tracker.ros.collector import PoseCollector
from human_tracker.ros.common import shutdown
from human_tracker.ros.image_conversion import message_to_bgr8
from human_tracker.ros.processes import NodeProcess, use_ros_environment
from human_tracker.vision.filter.contour_filter import box_from_state
from human_tracker.vision.filter.templates import fit_template, head_and_shoulders

__all__ = ['run_demo', 'demo_problems', 'node_arguments', 'main']


def node_arguments(
    camera_topic: str,
    compressed: bool,
    init_box: tuple[float, float, float, float] | None = None,
    motion_input: str = 'none',
    reliable: bool = True,
    depth: int = 100,
) -> list[str]:
    """``--ros-args`` for a node fed by a bag's camera topic (and, for the tracker, a motion cue);
    ``reliable``: a reliable subscription holding up to ``depth`` frames not yet taken."""
    args = ['--ros-args', '-p', f'image_transport:={"compressed" if compressed else "raw"}']
    if init_box is not None:
        args += ['-p', 'init_box:=[' + ', '.join(f'{v:.2f}' for v in init_box) + ']']
    if motion_input != 'none':
        args += ['-p', f'motion_input:={motion_input}']
    if reliable:
        # Every frame of the replay must be tracked so that it can be scored.
        args += ['-p', 'qos_reliability:=reliable', '-p', f'qos_depth:={depth}']
    args += [
        '-r',
        f'{"image/compressed" if compressed else "image"}:={camera_topic}',
        '-r',
        f'camera_info:={CAMERA_INFO_TOPIC}',
    ]
    return args


def run_demo(bag: Path, out: Path, *, domain_id: int | None = None, rate: float = 1.0) -> dict[str, object]:
    """Replay ``bag`` through background_node and tracker_node over DDS; write results to ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    frames = list(read_frames(bag))
    if not frames:
        raise SystemExit(f'demo: {bag} has no camera frames')
    first = frames[0]
    if first.ground_truth is None:
        raise SystemExit(f'demo: {bag} has no ground truth on its first frame to initialise from')
    compressed = hasattr(first.message, 'format')
    camera_topic = '/camera/image_raw/compressed' if compressed else '/camera/image_raw'
    domain_id = domain_id if domain_id is not None else 100 + os.getpid() % 100
    env = use_ros_environment(domain_id)

    rclpy.init()
    collector = PoseCollector()
    # When each frame reached this process too: a pose's arrival minus its frame's is the chain's
    # end-to-end latency (the frames are read raw: their stamp only, no decoding).
    frame_arrivals: dict[int, float] = {}
    message_type = CompressedImage if compressed else Image
    collector.create_subscription(
        message_type,
        camera_topic,
        lambda raw: frame_arrivals.setdefault(_cdr_stamp(raw), time.monotonic()),
        QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE),
        raw=True,
    )
    executor = SingleThreadedExecutor()
    executor.add_node(collector)
    background = NodeProcess(
        'human_tracker.ros.background_node', node_arguments(camera_topic, compressed), env, out / 'background_node.log'
    )
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        node_arguments(camera_topic, compressed, first.ground_truth, motion_input='foreground'),
        env,
        out / 'tracker_node.log',
    )
    player = NodeProcess(
        'human_tracker.ros.bag_play',
        # Both background_node and tracker_node subscribe to the camera; the replay starts when
        # both have compiled their kernels and spin (a subscriber alone may still be starting).
        [
            str(bag),
            '--rate',
            str(rate),
            '--wait-for-subscribers',
            camera_topic,
            '2',
            '--wait-for-ready',
            str(background.ready_node),
            str(tracker.ready_node),
        ],
        env,
        out / 'bag_play.log',
    )
    try:
        background.start()
        tracker.start()
        if not collector.wait_for_publisher(executor, 60.0):
            raise SystemExit(f'demo: tracker_node did not come up; its log:\n{tracker.output()}')
        player.start()
        while player.process is not None and player.process.poll() is None:
            executor.spin_once(timeout_sec=0.05)
        # Poses in flight when the bag ends still count: wait until all arrived (bounded), and
        # for the nodes' diagnostics after the last frame.
        deadline = time.monotonic() + 10.0
        while len(collector.poses) < len(frames) and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        settled = time.monotonic() + 1.5
        while time.monotonic() < settled:
            executor.spin_once(timeout_sec=0.05)
        if player.wait(5.0) != 0:
            raise SystemExit(f'demo: bag_play failed; its log:\n{player.output()}')
    finally:
        tracker.stop()
        background.stop()
        player.stop()
        executor.shutdown()
        collector.destroy_node()
        shutdown()

    template = head_and_shoulders()
    predicted: list[tuple[float, float, float, float] | None] = []
    writer = None
    with (out / 'poses.csv').open('w', newline='') as handle:
        table = csv.writer(handle)
        # The offline command's columns (confidence is not carried by the topics), then the
        # metric position from the pose topic.
        table.writerow([*POSE_COLUMNS, 'pos_x_m', 'pos_y_m', 'pos_z_m'])
        for frame in frames:
            contour = collector.contours.get(frame.stamp_ns)
            pose = collector.poses.get(frame.stamp_ns)
            box = None
            if contour is not None and pose is not None:
                state, shape = fit_template(template, contour)
                box = box_from_state(state, template)
                p = pose.pose.pose.position
                metric = [round(v, 4) for v in (p.x, p.y, p.z)]
                supports = [''] * (len(POSE_COLUMNS) - POSE_COLUMNS.index('shape') - 1)
                table.writerow(
                    [
                        frame.index,
                        frame.stamp_ns,
                        *np.round(state, 4),
                        '',
                        'TRACKING',
                        *np.round(box, 2),
                        shape.name,
                        *supports,
                        *metric,
                    ]
                )
            else:
                # Blank to the end of the row: the columns after the status, then the metric ones.
                blanks = len(POSE_COLUMNS) - POSE_COLUMNS.index('status') - 1 + 3
                table.writerow([frame.index, frame.stamp_ns, *[''] * 5, 'NO_POSE', *[''] * blanks])
            predicted.append(box)
            image = annotate(
                message_to_bgr8(frame.message),
                contour=contour,
                box=box,
                truth=frame.ground_truth,
                label=f'frame {frame.index}',
            )
            if writer is None:
                height, width = image.shape[:2]
                writer = cv2.VideoWriter(
                    str(out / 'tracking.mp4'), cv2.VideoWriter_fourcc(*'mp4v'), 30.0, (width, height)
                )
            writer.write(image)
    if writer is not None:
        writer.release()
    summary: dict[str, object] = {
        'bag': str(bag),
        'mode': 'bag_play -> background_node -> tracker_node (motion_input foreground) -> collector, '
        'separate processes over DDS',
        'frames': len(frames),
        'poses_received': len(collector.poses),
        'frame_ids': sorted(collector.frame_ids),
        'start': f"from the first frame's ground-truth box {list(first.ground_truth)} (init_box)",
        **_speed(collector, frame_arrivals, frames),
        **summarise(predicted, [f.ground_truth for f in frames]),
    }
    (out / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
    return summary


def _cdr_stamp(raw: bytes) -> int:
    """The header stamp (ns) of a serialised image message: after CDR's 4-byte encapsulation
    header, ``header.stamp.sec`` (int32) and ``nanosec`` (uint32), little-endian."""
    return int.from_bytes(raw[4:8], 'little', signed=True) * 1_000_000_000 + int.from_bytes(raw[8:12], 'little')


def _speed(collector: PoseCollector, frame_arrivals: dict[int, float], frames: list) -> dict[str, object]:
    """What the run says of speed: each node's processing time per frame (its ``/diagnostics``,
    the mean over its last frames) and the frames per second of processing the chain sustains;
    the end-to-end latency, each frame's pose arrival minus the frame's own (median and 95th
    percentile, ms)."""
    stages = {name: collector.diagnostics.get(f'/{name}', {}) for name in ('background_node', 'tracker_node')}
    ms = {name: float(values['processing_ms']) for name, values in stages.items() if 'processing_ms' in values}
    latencies = [
        1000.0 * (collector.pose_arrivals[f.stamp_ns] - frame_arrivals[f.stamp_ns])
        for f in frames
        if f.stamp_ns in collector.pose_arrivals and f.stamp_ns in frame_arrivals
    ]
    return {
        'processing_ms_per_frame': {name: round(value, 2) for name, value in ms.items()},
        'processing_fps': round(1000.0 / sum(ms.values()), 1) if ms and sum(ms.values()) > 0 else None,
        'latency_ms_median': round(float(np.median(latencies)), 1) if latencies else None,
        'latency_ms_p95': round(float(np.percentile(latencies, 95)), 1) if latencies else None,
    }


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m human_tracker.demo``."""
    parser = argparse.ArgumentParser(description='Replay a bag through tracker_node over DDS and score it.')
    parser.add_argument('--bag', type=Path, default=Path('bags/head_basic'))
    parser.add_argument('--out', type=Path, default=Path('out/demo'))
    parser.add_argument('--rate', type=float, default=1.0, help='replay rate factor')
    parser.add_argument(
        '--min-precision',
        type=float,
        default=0.95,
        help='fail below this precision at 20 px (default 0.95; the bundled bag gives 1.0)',
    )
    options = parser.parse_args(argv)
    summary = run_demo(options.bag, options.out, rate=options.rate)
    stages = ', '.join(f'{name} {value} ms' for name, value in summary['processing_ms_per_frame'].items())
    print(
        f'demo: started {summary["start"]}; {summary["poses_received"]}/{summary["frames"]} poses over DDS; '
        f'precision at 20 px {summary["precision_20px"]:.3f}, '
        f'mean centre error {summary["mean_centre_error_px"]:.1f} px'
    )
    print(
        f'demo: processing per frame {stages} ({summary["processing_fps"]} frames/s of processing); '
        f'latency from frame to pose {summary["latency_ms_median"]} ms median, {summary["latency_ms_p95"]} ms p95 '
        f"(replayed at {options.rate}x the camera's pace)"
    )
    print(f'demo: wrote {options.out}/tracking.mp4, poses.csv, summary.json')
    problems = demo_problems(summary, options.min_precision)
    for problem in problems:
        print(f'demo: FAILED: {problem} (logs of the nodes in {options.out})', file=sys.stderr)
    return 1 if problems else 0


def demo_problems(summary: dict[str, object], min_precision: float) -> list[str]:
    """What is wrong with a demo run: missing poses, precision below ``min_precision``."""
    problems = []
    if summary['poses_received'] != summary['frames']:
        problems.append(f'{summary["poses_received"]} poses for {summary["frames"]} frames')
    if float(summary['precision_20px']) < min_precision:
        problems.append(f'precision at 20 px {summary["precision_20px"]:.3f} < {min_precision}')
    return problems


if __name__ == '__main__':
    sys.exit(main())
