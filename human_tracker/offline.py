"""Offline tracking of a sequence, as fast as the machine allows (no ROS graph): the
``human_tracker track`` command.

The same core as the nodes runs on every frame: the motion cue (background subtraction,
optical flow or none), skin labels (§3.2, colour input only) and the
:class:`~human_tracker.vision.target.TargetTracker`. Without
an initial box the tracker starts by itself from motion (§2.5); with one, from that box in
the first frame (the protocol of tracking benchmarks).
"""

from __future__ import annotations

import csv
import json
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
from tqdm import tqdm

from human_tracker.drawing import annotate
from human_tracker.evaluation.metrics import Box, summarise
from human_tracker.evaluation.plots import plot_run
from human_tracker.io.images import to_mono8
from human_tracker.io.sequences import open_sequence
from human_tracker.vision.background import BackgroundModel
from human_tracker.vision.optical_flow import OpticalFlow
from human_tracker.vision.resolution import to_working, working_scale
from human_tracker.vision.skin import SkinSegmenter, default_skin_model, has_colour
from human_tracker.vision.target import TargetParameters, TargetTracker, parameters_for
from human_tracker.vision.templates import make_template
from human_tracker.vision.tracker import TrackerParameters, check_box_in_image

__all__ = ['CUES', 'TrackOptions', 'track_sequence', 'POSE_COLUMNS']

CUES = ('background', 'flow', 'none')
POSE_COLUMNS = (
    'frame',
    'stamp_ns',
    'x',
    'y',
    'scale',
    'theta',
    'confidence',
    'status',
    'box_x',
    'box_y',
    'box_w',
    'box_h',
    'motion_support',
    'skin_support',
    'appearance_distance',
)


@dataclass
class TrackOptions:
    """What to track and how.

    Attributes:
        target: Built-in template name (``head`` or ``hand``); None: what the bag's ground
            truth outlines, else ``head``.
        init: First-frame box (x, y, w, h) of the target's reference region, or None to start
            from motion.
        cue: Motion cue: ``background``, ``flow`` or ``none``.
        skin: Whether to segment skin and use it (§3.2); None: for the hand only.
        template_file: JSON template replacing the built-in one (empty: built-in).
        filter_parameters: Particle-filter constants.
        target_parameters: Cue combination, initialisation and loss constants; None: the
            target's defaults.
        working_width: Overrides the target parameters' ``working_width`` (0: full size).
        video: Whether to write the annotated video.
        video_every: Write every this many frames to the video (a shorter file; same pace).
        progress: Whether to show a progress bar.
    """

    target: str | None = None
    init: Box | None = None
    cue: str = 'background'
    skin: bool | None = None
    template_file: str = ''
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    target_parameters: TargetParameters | None = None
    working_width: int | None = None
    video: bool = True
    video_every: int = 1
    progress: bool = True


def track_sequence(source: str | Path, out: str | Path, options: TrackOptions) -> dict[str, object]:
    """Track ``source`` (bag, video or frame folder); write poses.csv, summary.json, video, plots to ``out``.

    Returns:
        The summary (also written to ``summary.json``).

    Raises:
        SequenceError: The source cannot be read.
        ValueError: A bad option.
    """
    if options.cue not in CUES:
        raise ValueError(f'cue must be one of {", ".join(CUES)}, got {options.cue!r}')
    if options.video_every < 1:
        raise ValueError(f'video_every must be >= 1, got {options.video_every}')
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sequence = open_sequence(source)
    target = options.target or sequence.target or 'head'
    template = make_template(target, template_file=options.template_file)
    target_parameters = options.target_parameters or parameters_for(target)
    if options.working_width is not None:
        target_parameters = replace(target_parameters, working_width=options.working_width)
    tracker = TargetTracker(template, options.filter_parameters, target_parameters)
    background, flow = BackgroundModel(), OpticalFlow()
    use_skin = target == 'hand' if options.skin is None else options.skin
    segmenter = SkinSegmenter(default_skin_model()) if use_skin else None
    grey_frames = 0
    motion_set_aside = 0
    predicted: list[Box | None] = []
    truth: list[Box | None] = []
    writer = None
    elapsed = 0.0
    rejected: dict[str, int] = {}
    with (out / 'poses.csv').open('w', newline='') as handle:
        table = csv.writer(handle)
        table.writerow(POSE_COLUMNS)
        for frame in tqdm(sequence, desc=f'tracking {sequence.name}', unit='frame', disable=not options.progress):
            if frame.image is None:
                # Counted, written as a row, and scored as a miss where annotated: never lost.
                rejected[frame.rejected] = rejected.get(frame.rejected, 0) + 1
                predicted.append(None)
                truth.append(frame.ground_truth)
                table.writerow([frame.index, frame.stamp_ns, *[''] * 5, 'REJECTED', *[''] * 7])
                continue
            start = time.perf_counter()
            gray = to_mono8(frame.image)
            # The cues are computed at the working resolution, as the tracker fits there.
            working = to_working(gray, target_parameters.working_width)
            motion = (
                background.apply(working)
                if options.cue == 'background'
                else flow.apply(working)[1]
                if options.cue == 'flow'
                else None
            )
            skin = None
            if segmenter is not None and has_colour(frame.image):
                width = target_parameters.working_width
                scale = working_scale(frame.image.shape[1], width)
                skin = segmenter.segment(to_working(frame.image, width), scale)
            elif segmenter is not None:
                grey_frames += 1
            if frame.index == 0 and options.init is not None:
                check_box_in_image(options.init, frame.image.shape)
                tracker.initialise_from_box(options.init)
            result = tracker.process(frame.image if frame.image.ndim == 3 else gray, motion, skin)
            elapsed += time.perf_counter() - start
            motion_set_aside += result.motion_set_aside
            estimate = result.estimate
            box = estimate.box if result.tracking else None
            predicted.append(box)
            truth.append(frame.ground_truth)
            if estimate is None:
                table.writerow([frame.index, frame.stamp_ns, *[''] * 5, result.status, *[''] * 7])
            else:
                x, y, s, theta = (round(float(v), 4) for v in estimate.state)
                shown = [round(v, 2) for v in estimate.box] if result.tracking else ['', '', '', '']
                support = (estimate.motion_support, estimate.skin_support, estimate.appearance_distance)
                table.writerow(
                    [
                        *(frame.index, frame.stamp_ns, x, y, s, theta, round(estimate.confidence, 4), result.status),
                        *shown,
                        *(round(v, 4) for v in support),
                    ]
                )
            if options.video and frame.index % options.video_every == 0:
                label = f'{sequence.name} {frame.index} {result.status}'
                image = annotate(
                    frame.image,
                    contour=None if estimate is None else estimate.contour,
                    box=box,
                    truth=frame.ground_truth,
                    label=label,
                    detections=result.detections,
                )
                if writer is None:
                    height, width = image.shape[:2]
                    writer = cv2.VideoWriter(
                        str(out / 'tracking.mp4'),
                        cv2.VideoWriter_fourcc(*'mp4v'),
                        sequence.fps / options.video_every,
                        (width, height),
                    )
                writer.write(image)
    if writer is not None:
        writer.release()
    summary: dict[str, object] = {
        'source': str(source),
        'target': target,
        'cue': options.cue,
        'skin': use_skin,
        'working_width': target_parameters.working_width,
        'frames_without_colour': grey_frames,
        'frames_motion_set_aside': motion_set_aside,
        'init': list(options.init) if options.init is not None else 'motion',
        'frames': len(predicted),
        'frames_processed': len(predicted) - sum(rejected.values()),
        'frames_rejected': sum(rejected.values()),
        'rejected_reasons': rejected,
        'frames_tracked': int(sum(b is not None for b in predicted)),
        'fps': round((len(predicted) - sum(rejected.values())) / elapsed, 2) if elapsed > 0 else None,
        'ms_per_frame': round(1000 * elapsed / max(len(predicted) - sum(rejected.values()), 1), 3),
    }
    if any(t is not None for t in truth):
        summary.update(summarise(predicted, truth))
    summary['plots'] = [p.name for p in plot_run(out, predicted, truth, sequence.name)]
    (out / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
    return summary


def read_poses(path: str | Path) -> list[Box | None]:
    """Boxes from a ``poses.csv`` written by :func:`track_sequence` (None where not tracked).

    Raises:
        ValueError: The file is not such a table (its header lacks the box columns, or a box
            value is not a number); the message names the file.
    """
    columns = ('box_x', 'box_y', 'box_w', 'box_h')
    boxes: list[Box | None] = []
    try:
        with Path(path).open(newline='') as handle:
            reader = csv.DictReader(handle)
            missing = [c for c in columns if c not in (reader.fieldnames or [])]
            if missing:
                raise ValueError(f'{path} is not a poses.csv written by `track`: no column {", ".join(missing)}')
            for row in reader:
                values = [row[k] for k in columns]
                boxes.append(None if '' in values or None in values else tuple(float(v) for v in values))
    except (UnicodeDecodeError, csv.Error) as err:
        raise ValueError(f'{path} is not a poses.csv written by `track`: {err}') from err
    return boxes
