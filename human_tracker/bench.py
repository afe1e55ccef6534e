"""``make bench``: speed and accuracy, measured in one run on this machine.

- speed: ms per frame of each stage and of the per-frame pipeline at 640x480 and 320x240,
  the particle filter at 250-2000 particles, and OpenCV's trackers on the same frames;
- accuracy: ours against CamShift, MIL, KCF and CSRT on the bundled bags and the real
  sequences in ``../shared/data/real`` (when present), same frames, same first box; and
  the skin labels' precision and recall on the hand bags and hand-labelled real frames;
- conditions: ours with ``min_target_width`` and without it on real sequences set in frames
  twice as wide and high, with the skin stage's exposure normalisation and without it on
  ``hand2`` dimmed, with the particles carried by the camera's motion and without on real
  sequences shaken, and with slow frames waiting for their own faces and without on real
  sequences at a third of their rate (:mod:`~human_tracker.evaluation.conditions`); and two people on the
  ``people_crossing`` bag, seed by seed (:mod:`~human_tracker.evaluation.several_people`);
- latency: end-to-end over DDS, described below.

Results go to ``out/bench/results.json`` and ``out/bench/results.md``.

A camera simulator in this process publishes raw 640x480 bgr8 frames of a bundled bag,
stamped with the time they are sent, to the package's nodes started as OS processes:

- ``pipeline``: one process (camera subscriber -> background subtraction -> tracker);
- ``separate``: ``background_node`` and ``tracker_node`` (masks matched by stamp).

Each layout runs at 30 Hz (a camera's pace: frames are sent on a timer whatever happens)
and at full speed (the next frame is sent as soon as the pose of the previous one arrives,
so the figure is the chain's own rate). Latency is pose arrival time minus image stamp; beside
it, the processing time on the frame's path (the stages' diagnostics, running means over the
last 30 frames: the pipeline's whole chain, or the mask's stage plus the tracker) and the
median latency above it: what DDS, the executors and the waiting add. Every node
spins rclpy's SingleThreadedExecutor (the experimental EventsExecutor delivered no frame to
these lifecycle nodes).
These are measurements of this machine at this moment: read the ratios, not the digits.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np
import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from human_tracker.evaluation.accuracy import (
    by_sequence_and_tracker,
    compare_on_folder,
    compare_on_sequence,
    covariance_table,
    precision_cell,
    real_people_table,
    wrong_cell,
)
from human_tracker.evaluation.facing import CLASSES
from human_tracker.io.bags import read_frames
from human_tracker.io.images import stamp_ns
from human_tracker.ros.collector import PoseCollector
from human_tracker.ros.common import shutdown
from human_tracker.ros.image_conversion import array_to_image, message_to_bgr8
from human_tracker.ros.processes import NodeProcess, use_ros_environment
from human_tracker.threads import default_threads, use_threads
from human_tracker.vision.filter.contour_filter import TrackerParameters

__all__ = ['measure_latency', 'main']

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


def _table(rows: list[dict[str, object]], columns: list[str]) -> str:
    lines = ['| ' + ' | '.join(columns) + ' |', '|' + '---|' * len(columns)]
    for row in rows:
        cells = []
        for column in columns:
            value = row.get(column, '')
            cells.append(f'{value:.3f}' if isinstance(value, float) else str(value))
        lines.append('| ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines) + '\n'


def _speed(bag: Path, contrib_python: Path | None) -> dict[str, object]:
    from human_tracker.evaluation.speed import stage_timings
    from human_tracker.io.sequences import open_sequence

    frames = list(open_sequence(bag))
    images, boxes = [f.image for f in frames], [f.ground_truth for f in frames]
    stages = {'640x480': stage_timings(images, boxes), '320x240': stage_timings(images, boxes, 0.5)}
    rows = compare_on_sequence(bag, contrib_python)
    baselines = {row['tracker']: row['ms_per_frame'] for row in rows}
    cpu = {row['tracker']: row['cpu_ms_per_frame'] for row in rows}
    ours = stages['640x480']['pipeline']
    ratios = {name: round(ms / ours, 3) for name, ms in baselines.items()}
    return {
        'stages_ms': stages,
        'trackers_ms_640x480': baselines,
        'trackers_cpu_ms_640x480': cpu,
        'opencv_threads': cv2.getNumThreads(),
        'baseline_ms_over_our_pipeline_ms': ratios,
    }


HEAD_SEQUENCES = ('david', 'david_colour', 'trellis', 'sunshade', 'seated_agbani', 'interview_alberto')


def _acceptance(results: dict[str, object]) -> list[dict[str, object]]:
    """The issues' bars against this run's figures: speed at 640x480, precision per sequence,
    confident-wrong frames, the start without a box, skin labels on HGR."""
    checks: list[dict[str, object]] = []

    def check(name: str, measured: float, bar: float | tuple[float, float], at_most: bool = False) -> None:
        if isinstance(bar, tuple):
            met = bar[0] <= measured <= bar[1]
        else:
            met = measured <= bar if at_most else measured >= bar
        checks.append({'check': name, 'measured': measured, 'bar': bar, 'met': met})

    speed = results.get('speed')
    if isinstance(speed, dict):
        stages, trackers = speed['stages_ms']['640x480'], speed['trackers_ms_640x480']
        check('particle filter step, 500 particles (ms) <= 1', stages['particle_filter_500'], 1.0, at_most=True)
        if 'CSRT' in trackers:
            check('head pipeline (ms) <= CSRT / 5', stages['pipeline'], round(trackers['CSRT'] / 5, 3), at_most=True)
            check('hand pipeline (ms) <= 3 KCF', stages['hand_pipeline'], round(3 * trackers['KCF'], 3), at_most=True)
            cpu = speed['trackers_cpu_ms_640x480']
            name = 'head pipeline, CPU of every thread (ms) <= CSRT / 5'
            check(name, stages['pipeline_cpu'], round(cpu['CSRT'] / 5, 3), at_most=True)
            name = 'hand pipeline, CPU of every thread (ms) <= 3 KCF'
            check(name, stages['hand_pipeline_cpu'], round(3 * cpu['KCF'], 3), at_most=True)
            # Issue 75: cheaper than KCF, OpenCV's cheapest box tracker people use.
            check('head pipeline (ms) <= KCF', stages['pipeline'], trackers['KCF'], at_most=True)
            name = 'head pipeline, CPU of every thread (ms) <= KCF'
            check(name, stages['pipeline_cpu'], cpu['KCF'], at_most=True)
            check(
                'hand pipeline (ms) <= 1.5 KCF', stages['hand_pipeline'], round(1.5 * trackers['KCF'], 3), at_most=True
            )
            if 'person_pipeline' in stages:
                # Two hands: a harder bar than the head and one hand.
                name = 'person pipeline, head and two hands (ms) <= 2 KCF'
                check(name, stages['person_pipeline'], round(2 * trackers['KCF'], 3), at_most=True)
        if 'person_pipeline' in stages:
            name = 'person pipeline, head and two hands (ms) <= 2.5 head pipeline'
            check(name, stages['person_pipeline'], round(2.5 * stages['pipeline'], 3), at_most=True)
    scores: dict[str, dict[str, float]] = {}
    wrong: dict[str, float] = {}
    falsely_lost: dict[str, float] = {}
    reported: dict[str, float] = {}  # a real head's annotated frames with a box, worst run
    consistency: dict[str, float] = {}  # the head bags' NEES
    held: dict[str, float] = {}  # a person's head beside a hand: the share under one id, worst run
    hand_ids: dict[str, tuple[float, int]] = {}  # a person's hand: IDF1 (mean), switches (most)
    for row in results.get('accuracy', []):  # type: ignore[union-attr]
        tracker, sequence = str(row['tracker']), str(row['sequence'])
        kind = tracker.split(' (')[0]
        name = f'{kind}, no box' if kind in ('ours', 'person') and 'no box' in tracker else kind
        # Mean over the runs: one seed of ours, or one draw of MIL, is luck on a hard sequence.
        scores.setdefault(sequence, {})[name] = float(row.get('precision_20px_mean', row['precision_20px']))
        if name.startswith(('ours', 'person')):
            # The worst run: a robot is told where a person is, wrongly, whichever seed it drew.
            wrong[f'{sequence} ({name})'] = float(row.get('confident_wrong_max', row.get('confident_wrong', 0.0)))
            if 'falsely_lost_max' in row:
                falsely_lost[f'{sequence} ({name})'] = float(row['falsely_lost_max'])
            if name.startswith('ours') and 'box_reported_min' in row:
                reported[f'{sequence} ({name})'] = float(row['box_reported_min'])
        if 'head_one_id_min' in row:
            held[f'{sequence} ({name})'] = float(row['head_one_id_min'])
        if 'head_one_id_min' in row and 'id_switches_max' in row:
            hand_ids[f'{sequence} ({name})'] = (float(row['idf1_mean']), int(row['id_switches_max']))
        if name == 'ours' and sequence.startswith('head_') and 'nees_mean' in row:
            consistency[sequence] = float(row['nees_mean'])
    for sequence, by in scores.items():
        rivals = [by[name] for name in ('CamShift', 'MIL', 'KCF') if name in by]
        check(f'{sequence}: mean precision at 20 px >= CamShift, MIL, KCF', by['ours'], max(rivals, default=0.0))
        if 'ours, no box' in by and sequence in HEAD_SEQUENCES:
            check(f'{sequence}: without a box >= 0.8 of with one', by['ours, no box'], round(0.8 * by['ours'], 3))
    at_csrt = [s for s in HEAD_SEQUENCES if s in scores and scores[s]['ours'] >= scores[s].get('CSRT', 1.0)]
    if any(s in scores for s in HEAD_SEQUENCES):
        check('head sequences where ours >= CSRT (of 6)', len(at_csrt), 4)
    # Issue 73, on every real head sequence (those run without a box too): CSRT's precision
    # from the first box, 0.9 of it without one; from the box and without, a box on at least
    # 0.95 of the annotated frames (the head stays in view on them) in the worst run.
    for sequence, by in scores.items():
        if 'ours, no box' not in by or 'hand' in sequence:
            continue
        if 'CSRT' in by:
            check(f'{sequence}: from the first box >= CSRT', by['ours'], by['CSRT'])
            check(f'{sequence}: without a box >= 0.9 CSRT', by['ours, no box'], round(0.9 * by['CSRT'], 3))
        for key in (f'{sequence} (ours)', f'{sequence} (ours, no box)'):
            if key in reported:
                check(f'{key}: annotated frames with a reported box, worst run >= 0.95', reported[key], 0.95)
    if 'hand2' in scores:
        check('hand2: mean precision at 20 px >= 0.6', scores['hand2']['ours'], 0.6)
        check('hand2: mean precision at 20 px >= CSRT', scores['hand2']['ours'], scores['hand2'].get('CSRT', 0.0))
        check('hand2: mean precision at 20 px >= 0.65', scores['hand2']['ours'], 0.65)
        if 'ours, no box' in scores['hand2']:
            check('hand2: from the box >= without one', scores['hand2']['ours'], scores['hand2']['ours, no box'])
    for name, share in wrong.items():
        check(f'{name}: confident-wrong share, worst run <= 0.05', share, 0.05, at_most=True)
    for name, share in falsely_lost.items():
        check(f'{name}: falsely lost share, worst run <= 0.05', share, 0.05, at_most=True)
    for name, share in held.items():
        check(f'{name}: the head keeps one id, share of frames, worst run >= 0.9', share, 0.9)
    for name, (idf1, switches) in hand_ids.items():
        check(f"{name}: the hand's IDF1, mean >= 0.8", idf1, 0.8)
        check(f'{name}: identity switches of the hand, worst run <= 1', switches, 1, at_most=True)
    for sequence, nees in consistency.items():
        check(f'{sequence}: pose NEES of x, y within a factor 2 of 2', nees, (1.0, 4.0))
    people: list[dict[str, object]] = results.get('people', [])  # type: ignore[assignment]
    if people:
        tracks = [name for name in people[0] if '/' in name]
        # The bar is the bag's replay, at the seed `track` and the nodes run by default; the
        # other seeds, beyond it, say how often another draw of the particles misses it.
        for row in (row for row in people if row['seed'] == TrackerParameters().seed):
            runs = f"people_crossing, two people, the replay's seed ({row['seed']})"
            worst = min(float(row[name]) for name in tracks)  # type: ignore[arg-type]
            check(f"{runs}: every track's precision at 20 px >= 0.9", worst, 0.9)
            check(f'{runs}: identity switches <= 0', row['id_switches'], 0, at_most=True)
            check(f'{runs}: IDF1 >= 0.9', row['idf1'], 0.9)
        runs = f'people_crossing, two people, {len(people)} seeds (beyond the bar)'
        worst = min(float(row[name]) for row in people for name in tracks)  # type: ignore[arg-type]
        check(f"{runs}: every track's precision at 20 px, worst seed >= 0.9", worst, 0.9)
        switched = sum(int(row['id_switches']) > 0 for row in people)  # type: ignore[call-overload]
        check(f'{runs}: seeds with an identity switch <= 0', switched, 0, at_most=True)
        check(f'{runs}: IDF1, worst seed >= 0.9', min(float(row['idf1']) for row in people), 0.9)  # type: ignore[arg-type]
    for row in results.get('real_people', []):  # type: ignore[union-attr]
        check(f'two real people side by side, seed {row["seed"]}: IDF1 >= 0.9', row['idf1'], 0.9)
    for row in results.get('latency', []):  # type: ignore[union-attr]
        if row['rate'] == 'full speed':
            continue
        layout = f'latency, {row["layout"]}, {row["rate"]}'
        if row.get('busy_processes'):
            layout += f', {row["busy_processes"]} busy processes'
        check(f'{layout}: poses received of {row["frames_sent"]} sent', row['poses_received'], row['frames_sent'])
        if row.get('busy_processes'):
            # Issue 75: beside busy processes, a frame waits at most 2 ms beyond its processing.
            check(f'{layout}: median above processing (ms) <= 2', row['above_processing_ms'], 2.0, at_most=True)
            check(f'{layout}: p95 (ms) < 33', row['latency_ms_p95'], 33.0, at_most=True)
        elif row['layout'] == 'separate':
            check(f'{layout}: median (ms) <= 5', row['latency_ms_median'], 5.0, at_most=True)
            check(f'{layout}: p95 (ms) <= 10', row['latency_ms_p95'], 10.0, at_most=True)
        else:
            check(f'{layout}: median above processing (ms) <= 1', row['above_processing_ms'], 1.0, at_most=True)
    for row in results.get('skin', []):  # type: ignore[union-attr]
        if 'f1' in row:
            name = f'{row["sequence"]}, {row["method"]}'
            check(f'{name}: skin F1 >= 0.92', float(row['f1']), 0.92)
            check(f'{name}: skin recall >= 0.9', float(row['recall']), 0.9)
    return checks


def _accuracy(bags: list[Path], real_data: Path, contrib_python: Path | None) -> list[dict[str, object]]:
    rows = [{'sequence': path.name, **row} for path in bags for row in compare_on_sequence(path, contrib_python)]
    for row in rows:
        print(json.dumps(row))
    for row in compare_on_folder(real_data, contrib_python) if real_data.is_dir() else ():
        rows.append(row)
        print(json.dumps(row))
    return rows


def _facing_table(rows: list[dict[str, object]]) -> str:
    """Our head's ``facing`` against the labels, per class, on the sequences labelled."""
    columns = ['sequence', 'tracker', *(f'facing_{c}_{m}' for c in CLASSES for m in ('precision', 'recall'))]
    return _table([row for row in rows if 'facing_unknown' in row], [*columns, 'facing_unknown'])


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


def _thread_policy(sequence: Path, init: str | None, out: Path, runs: int = 3) -> list[dict[str, object]]:
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


def _skin(real_data: Path) -> list[dict[str, object]]:
    from human_tracker.evaluation.skin import labelled_photo_scores, labelled_video_scores, scene_scores
    from human_tracker.vision.cues.skin import REGION_METHODS, SkinParameters

    labels = Path('test/data/vtest_skin_labels.json')
    hgr = real_data.parent / 'skin' / 'hgr'
    rows: list[dict[str, object]] = []
    for regions in REGION_METHODS:
        parameters = SkinParameters(regions=regions)
        rows += [
            {
                'sequence': name,
                'method': regions,
                'truth': 'generator (exact)',
                **scene_scores(Path('bags') / name, parameters=parameters),
            }
            for name in ('hand_wave', 'hand_cluttered', 'head_basic')
        ]
        if (real_data / 'vtest').exists():
            scores = labelled_video_scores(labels, real_data, parameters=parameters)
            rows.append({'sequence': 'vtest', 'method': regions, 'truth': 'hand-labelled faces', **scores})
        if hgr.is_dir():
            scores = labelled_photo_scores(hgr, parameters=parameters)
            rows.append({'sequence': 'hgr (178 photos)', 'method': regions, 'truth': 'pixel masks', **scores})
    for row in rows:
        print(json.dumps(row))
    return rows


def _readme_summary(results: dict[str, object]) -> str:
    """The README's results: real people (ours from the box and without, CSRT) and the speed."""
    real = by_sequence_and_tracker(results.get('accuracy', []))  # type: ignore[arg-type]
    lines = ['| | ' + ' | '.join(real) + ' |', '|---|' + '---|' * len(real)]
    for name in ('ours', 'ours, no box'):
        cells = [f'{precision_cell(by[name], spread=False)} ({wrong_cell(by[name])})' for by in real.values()]
        lines.append(f'| {name} | ' + ' | '.join(cells) + ' |')
    lines.append('| CSRT | ' + ' | '.join(precision_cell(by.get('CSRT')) for by in real.values()) + ' |')
    speed = results.get('speed')
    if isinstance(speed, dict) and 'CSRT' in speed['trackers_ms_640x480']:
        stages, trackers = speed['stages_ms']['640x480'], speed['trackers_ms_640x480']
        cpu = speed['trackers_cpu_ms_640x480']
        lines += [
            '',
            f'Speed in the same run, 640x480: the head pipeline {stages["pipeline"]:.1f} ms per frame, '
            f'{trackers["CSRT"] / stages["pipeline"]:.1f}x faster than CSRT ({trackers["CSRT"]:.1f} ms); '
            f'the hand pipeline {stages["hand_pipeline"]:.1f} ms, {stages["hand_pipeline"] / trackers["KCF"]:.1f}x '
            f'KCF ({trackers["KCF"]:.1f} ms); in CPU time of every thread (the face detector has its own), '
            f'{cpu["CSRT"] / stages["pipeline_cpu"]:.1f}x less than CSRT and '
            f'{stages["hand_pipeline_cpu"] / cpu["KCF"]:.1f}x KCF; one particle filter step with 500 particles '
            f'{stages["particle_filter_500"]:.2f} ms. Every tracker ran OpenCV on {_threads(speed)}.',
        ]
    return '\n'.join(lines) + '\n'


def _threads(speed: dict[str, object]) -> str:
    count = speed['opencv_threads']
    return f'{count} thread' if count == 1 else f'{count} threads'


def write_between_markers(path: Path, name: str, text: str) -> None:
    """Replace what lies between ``<!-- bench:NAME -->`` and ``<!-- /bench:NAME -->`` in ``path``.

    Raises:
        ValueError: The file lacks the pair of markers.
    """
    start, end = f'<!-- bench:{name} -->', f'<!-- /bench:{name} -->'
    content = path.read_text()
    head, found, rest = content.partition(start)
    _, found_end, tail = rest.partition(end)
    if not found or not found_end:
        raise ValueError(f'{path} has no {start} ... {end} block to write into')
    path.write_text(f'{head}{start}\n\n{text}\n{end}{tail}')


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m human_tracker.bench``."""
    parser = argparse.ArgumentParser(description='Speed, accuracy and latency, measured in one run.')
    parser.add_argument('--bag', type=Path, default=Path('bags/head_basic'))
    parser.add_argument('--out', type=Path, default=Path('out/bench'))
    parser.add_argument('--frames', type=int, default=240, help='frames per latency run (the bag is looped)')
    parser.add_argument('--contrib-python', type=Path, help='python of the virtualenv with opencv-contrib (KCF, CSRT)')
    parser.add_argument('--real-data', type=Path, default=Path('../shared/data/real'))
    parser.add_argument('--sections', default='speed,accuracy,conditions,latency,threads')
    parser.add_argument('--report', type=Path, help='also write the markdown report here (docs/benchmark.md)')
    parser.add_argument(
        '--readme', type=Path, help="write the summary of real people and speed into this README's bench block"
    )
    parser.add_argument('--evaluation', type=Path, help="write the table of real people into this file's bench block")
    options = parser.parse_args(argv)
    use_threads(default_threads())
    options.out.mkdir(parents=True, exist_ok=True)
    sections = set(options.sections.split(','))
    contrib = options.contrib_python if options.contrib_python and options.contrib_python.exists() else None
    results: dict[str, object] = {}
    report = [
        '# human_tracker benchmark (this machine, one run)\n',
        f'Written by `make bench` on {platform.node()} ({os.cpu_count()} cores), {time.strftime("%Y-%m-%d")}. '
        'Ours runs with five seeds (a hand ten; mean, min, max), MIL three times; every tracker on the same frames '
        'from the same first box. confident_wrong: share of annotated frames reported TRACKING more than '
        'twice the target width from the truth; falsely_lost: share of annotated frames not reported TRACKING while '
        "the filter's estimate is within the target's width of the truth.\n",
    ]
    if 'speed' in sections:
        speed = _speed(options.bag, contrib)
        results['speed'] = speed
        stage_rows = [
            {'stage': name, **{res: values[name] for res, values in speed['stages_ms'].items()}}
            for name in speed['stages_ms']['640x480']
        ]
        report += [
            '## ms per frame, by stage\n',
            'The `*pipeline*` rows time `FramePipeline` (human_tracker/vision/frame_pipeline.py), the frame path '
            'the `pipeline` node, the tracker node and `track` run, after the image message is converted; the other '
            'rows break it down by stage.\n',
            _table(stage_rows, ['stage', '640x480', '320x240']),
        ]
        tracker_rows = [
            {
                'tracker': k,
                'ms_per_frame': v,
                'cpu_ms_per_frame': speed['trackers_cpu_ms_640x480'][k],
                'ratio_to_our_pipeline': speed['baseline_ms_over_our_pipeline_ms'][k],
            }
            for k, v in speed['trackers_ms_640x480'].items()
        ]
        report += [
            f'## trackers at 640x480 (ratio > 1: slower than our pipeline; OpenCV on {_threads(speed)} for '
            "every tracker; cpu: every thread of the process, our face detector's included)\n",
            _table(tracker_rows, ['tracker', 'ms_per_frame', 'cpu_ms_per_frame', 'ratio_to_our_pipeline']),
        ]
    if 'accuracy' in sections:
        bags = sorted(p for p in Path('bags').iterdir() if p.is_dir())
        results['accuracy'] = _accuracy(bags, options.real_data, contrib)
        columns = ['sequence', 'tracker', 'precision_20px', 'success_auc', 'mean_centre_error_px', 'confident_wrong']
        columns += ['ms_per_frame', 'cpu_ms_per_frame']
        columns += ['runs', 'precision_20px_mean', 'precision_20px_min', 'precision_20px_max', 'confident_wrong_max']
        columns += ['falsely_lost_max', 'box_reported_min']
        columns += ['nees_mean', 'nees_within_95', 'particles_least', 'particles_most']
        report += [
            '## accuracy (same frames, same first box; figures of the first run; precision and the worst'
            ' confident-wrong share over all runs; particles: the fewest and most any run used on a frame)\n',
            _table(results['accuracy'], columns),
        ]
        report += [
            '## where a head faces (labels by eye on every tenth frame, pooled over the runs; '
            'unknown: labelled frames reported unknown or not followed)\n',
            _facing_table(results['accuracy']),  # type: ignore[arg-type]
        ]
        results['skin'] = _skin(options.real_data)
        columns = ['sequence', 'method', 'truth', 'precision', 'recall', 'f1', 'mean_photo_f1']
        columns += ['labelled_fraction', 'regions', 'regions_found']
        report += ['## skin labels (§3.2) against true skin\n', _table(results['skin'], columns)]
    conditions: dict[str, str] = {}  # the tables, by their block in evaluation.md
    if 'conditions' in sections:
        from human_tracker.evaluation.conditions import (
            DIM_BRIGHTNESS,
            SHAKE_MARGIN,
            SLOW_STEP,
            dim_light_rows,
            shaken_camera_rows,
            slow_camera_rows,
            small_target_rows,
        )
        from human_tracker.evaluation.several_people import REAL_PAIR, side_by_side, two_people_rows

        titles = {
            'small': 'small targets in wide frames (real sequences in frames twice as wide and high)',
            'dim': f'dim light (the real hand at {DIM_BRIGHTNESS:g} of its brightness)',
            'shake': f'a shaking camera (real sequences cropped {SHAKE_MARGIN} px in, the crop jolting)',
            'slow': f'a slow camera (real sequences, one frame in {SLOW_STEP})',
            'people': 'two people (people_crossing as a person, --max-people 2), seed by seed',
            'real_people': f'two real people side by side ({" and ".join(REAL_PAIR)}, --max-people 2), seed by seed',
        }
        results['small'] = small_target_rows(options.real_data, options.out / 'conditions')
        results['dim'] = dim_light_rows(options.real_data, options.out / 'conditions')
        results['shake'] = shaken_camera_rows(options.real_data, options.out / 'conditions')
        results['slow'] = slow_camera_rows(options.real_data, options.out / 'conditions')
        results['people'] = two_people_rows(Path('bags/people_crossing'), options.out / 'conditions' / 'people')
        pair = side_by_side(*(options.real_data / name for name in REAL_PAIR), options.out / 'conditions' / 'pair')
        real_people = options.out / 'conditions' / 'real_people'
        results['real_people'] = [] if pair is None else two_people_rows(pair, real_people, seeds=range(5))
        for name, title in titles.items():
            if results[name]:
                # Each row's columns in order: the sequence, the setting, the start, the figures.
                conditions[name] = _table(results[name], list(results[name][0]))  # type: ignore[index]
                report += [f'## {title}\n', conditions[name]]
    if 'latency' in sections:
        env = use_ros_environment(int(os.environ.get('ROS_DOMAIN_ID', 150 + os.getpid() % 50)))
        bag_frames = list(read_frames(options.bag))
        images = [array_to_image(message_to_bgr8(f.message), 'bgr8') for f in bag_frames]
        frames = [images[i % len(images)] for i in range(options.frames)]
        box = [float(v) for v in bag_frames[0].ground_truth]
        rclpy.init()
        rows = []
        try:
            # (layout, rate, busy processes beside it): a robot's computer runs other nodes.
            for layout, rate, load in (
                ('pipeline', 30.0, 0),
                ('pipeline', None, 0),
                ('pipeline', 30.0, 2),
                ('separate', 30.0, 0),
                ('separate', None, 0),
            ):
                with busy_processes(load):
                    rows.append(
                        {**measure_latency(layout, rate, frames, box, options.out, env), 'busy_processes': load}
                    )
                print(json.dumps(rows[-1]))
        finally:
            shutdown()
        results['latency'] = rows
        columns = [
            'layout',
            'rate',
            'busy_processes',
            'frames_sent',
            'poses_received',
            'throughput_hz',
            'latency_ms_median',
            'latency_ms_p95',
            'processing_ms',
            'above_processing_ms',
            'executor',
            'frames_dropped',
            'tracker_frames_received',
            'tracker_frames_without_mask',
            'tracker_frames_never_received',
        ]
        report += ['## end-to-end latency over DDS\n', _table(rows, columns)]
    checks = _acceptance(results)
    if checks:
        results['acceptance'] = checks
        table = _table(checks, ['check', 'measured', 'bar', 'met'])
        report += ["## the issues' acceptance bars, checked on this run\n", table]
    if 'threads' in sections:
        david = options.real_data / 'david'
        sequence, init = (david, '122,58,75,97') if david.exists() else (options.bag, None)
        results['threads'] = _thread_policy(sequence, init, options.out / 'threads')
        columns = ['sequence', 'busy_processes', 'threads', 'fps_median', 'fps_min', 'fps_max']
        report += [
            '## thread policy: offline frames per second (3 runs each)\n',
            _table(results['threads'], columns),
        ]
    (options.out / 'results.json').write_text(json.dumps(results, indent=2) + '\n')
    (options.out / 'results.md').write_text('\n'.join(report))
    if options.report:
        options.report.write_text('\n'.join(report))
    if 'accuracy' in sections:
        if options.readme:
            write_between_markers(options.readme, 'summary', _readme_summary(results))
        if options.evaluation:
            write_between_markers(options.evaluation, 'real', real_people_table(results['accuracy']))  # type: ignore[arg-type]
            write_between_markers(options.evaluation, 'covariance', covariance_table(results['accuracy']))  # type: ignore[arg-type]
            write_between_markers(options.evaluation, 'facing', _facing_table(results['accuracy']))  # type: ignore[arg-type]
    if options.evaluation:
        for name, table in conditions.items():
            write_between_markers(options.evaluation, name, table)
    print('\n'.join(report))
    return 0


if __name__ == '__main__':
    sys.exit(main())
