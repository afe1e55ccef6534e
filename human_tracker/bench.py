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
import sys
import time
from pathlib import Path

import cv2
import rclpy

from human_tracker.evaluation.acceptance import acceptance_rows
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
from human_tracker.evaluation.latency import busy_processes, measure_latency, thread_policy
from human_tracker.io.bags import read_frames
from human_tracker.ros.common import shutdown
from human_tracker.ros.image_conversion import array_to_image, message_to_bgr8
from human_tracker.ros.processes import use_ros_environment
from human_tracker.threads import default_threads, use_threads

__all__ = ['main']


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
    rows += _skin_of_faces(real_data)
    for row in rows:
        print(json.dumps(row))
    return rows


def _skin_of_faces(real_data: Path) -> list[dict[str, object]]:
    """The general classes and the classes learnt from each frame's faces, on the skin masks
    drawn on real frames (test/data/skin_masks)."""
    from human_tracker.evaluation.skin import labelled_mask_scores, labels_from_faces
    from human_tracker.vision.cues.skin import default_skin_model, segment_frame
    from human_tracker.vision.faces.yunet import YuNetDetector, yunet_available

    masks = Path('test/data/skin_masks')
    if not yunet_available():
        return []
    prior = default_skin_model()
    methods = {
        'cells, general': lambda image: segment_frame(image, prior),
        'cells, from faces': labels_from_faces(YuNetDetector().detect, prior),
    }
    rows: list[dict[str, object]] = []
    for folder in sorted(path for path in masks.iterdir() if path.is_dir()):
        if not (real_data / folder.name).is_dir():
            continue
        for method, labels_of in methods.items():
            scores = labelled_mask_scores(folder, real_data / folder.name, labels_of)
            rows.append({'sequence': folder.name, 'method': method, 'truth': 'drawn masks', **scores})
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
    checks = acceptance_rows(results)
    if checks:
        results['acceptance'] = checks
        table = _table(checks, ['check', 'measured', 'bar', 'met'])
        report += ["## the issues' acceptance bars, checked on this run\n", table]
    if 'threads' in sections:
        david = options.real_data / 'david'
        sequence, init = (david, '122,58,75,97') if david.exists() else (options.bag, None)
        results['threads'] = thread_policy(sequence, init, options.out / 'threads')
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
