"""Offline tracking of a sequence, as fast as the machine allows (no ROS graph): the
``human_tracker track`` command.

The frame path the nodes run (:class:`~human_tracker.vision.frame_pipeline.FramePipeline`),
on every frame: the motion cue (background subtraction, optical flow or none), skin labels
(§3.2, colour input only) and the targets' trackers. Without
an initial box the tracker starts by itself from motion (§2.5); with one, from that box in
the first frame (the protocol of tracking benchmarks).
"""

from __future__ import annotations

import csv
import json
import logging
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from human_tracker.drawing import annotate, draw_target
from human_tracker.evaluation.identity import identity_scores, one_track
from human_tracker.evaluation.metrics import Box, summarise
from human_tracker.evaluation.plots import plot_run
from human_tracker.io.poses import POSE_COLUMNS
from human_tracker.io.sequences import open_sequence
from human_tracker.vision.cues.background import BackgroundModel
from human_tracker.vision.cues.skin import SkinParameters
from human_tracker.vision.cues.stages import MOTION_CUES, Frame
from human_tracker.vision.filter.contour_filter import TrackerParameters, check_box_in_image
from human_tracker.vision.frame_pipeline import FramePipeline
from human_tracker.vision.people.persons import TrackedTarget, kinds_of, targets_line
from human_tracker.vision.track.outcomes import state_words
from human_tracker.vision.track.parameters import TargetParameters, parameters_for

__all__ = [
    'CUES',
    'TrackOptions',
    'track_sequence',
]

CUES = MOTION_CUES
GREY_WARNING = (
    '{name}: frame {index} has no colour (a grey-level camera?): no skin can be found in it, so no hand is '
    'followed on such frames (frames_without_colour in summary.json)'
)
_LOG = logging.getLogger(__name__)
_AFTER_STATUS = len(POSE_COLUMNS) - POSE_COLUMNS.index('status') - 1


@dataclass
class TrackOptions:
    """What to track and how.

    Attributes:
        target: ``head``, ``hand`` or ``person`` (a head and hands, each with its id,
            :mod:`~human_tracker.vision.people.persons`); None: what the bag's ground truth
            outlines, else ``head``.
        hands: A person's hands followed (0 to 2).
        max_people: The most people followed at once (a person).
        init: First-frame box (x, y, w, h) of the target's reference region, or None to start
            from motion.
        init_kind: For a person, which target ``init`` is the box of (``head`` or ``hand``);
            None: what the bag's ground truth outlines, else the head.
        cue: Motion cue: ``background``, ``flow`` or ``none``.
        skin: Whether to segment skin and use it (§3.2); None: when a hand is followed.
        skin_parameters: Skin segmentation constants.
        template_file: JSON template replacing the built-in one (empty: built-in; one target).
        filter_parameters: Particle-filter constants.
        target_parameters: Cue combination, initialisation and loss constants; None: the
            target's defaults (one target).
        working_width: Overrides the target parameters' ``working_width`` (0: full size).
        video: Whether to write the annotated video.
        video_every: Write every this many frames to the video (a shorter file; same pace).
        progress: Whether to show a progress bar.
        fps: The frame rate, Hz, of a folder of frames or a video, which stamps their frames
            (the tracker's ``detector_wait_interval`` reads the stamps); None: the video's own,
            or 30. A bag's frames keep their own stamps.
        pipeline: A frame path built elsewhere (the pipeline node's, from its parameter file:
            :func:`~human_tracker.ros.configured.configured_pipeline`) for ``target``; its own
            settings then replace ``hands`` to ``working_width``.
    """

    target: str | None = None
    init: Box | None = None
    init_kind: str | None = None
    hands: int = 1
    max_people: int = 1
    cue: str = 'background'
    skin: bool | None = None
    skin_parameters: SkinParameters = field(default_factory=SkinParameters)
    template_file: str = ''
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    target_parameters: TargetParameters | None = None
    working_width: int | None = None
    video: bool = True
    video_every: int = 1
    progress: bool = True
    fps: float | None = None
    pipeline: FramePipeline | None = None


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
    if options.fps is not None and not options.fps > 0:
        raise ValueError(f'fps must be > 0, got {options.fps}')
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sequence = open_sequence(source)
    if options.fps is not None:
        sequence.fps = options.fps
    target = options.target or sequence.target or 'head'
    pipeline = options.pipeline or _frame_path(target, options)
    kinds = pipeline.people.kinds
    people = pipeline.people
    names = [slot.name for slot in people.slots]
    kind_of = {slot.name: slot.kind for slot in people.slots}
    width = people.trackers[0].parameters.working_width
    init_kind = options.init_kind or (sequence.target if sequence.target in kinds else kinds[0])
    if init_kind not in kinds:
        raise ValueError(f'init_kind must be one of {", ".join(kinds)}, got {init_kind!r}')
    grey_frames = 0
    motion_set_aside = 0
    # By target slot (``head``, ``hand``, ``person_2/head``, ...): None or 0 where it did not run.
    predicted: dict[str, list[Box | None]] = {name: [] for name in names}
    estimated: dict[str, list[Box | None]] = {name: [] for name in names}  # the filter's, any state
    ids: dict[str, list[int]] = {name: [] for name in names}
    truth: list[Box | None] = []
    tracks: dict[str, list[Box | None]] = {}  # several ground-truth tracks, by name
    writer = None
    elapsed = busy = 0.0
    rejected: dict[str, int] = {}
    particles: list[int] = []  # every estimate's particle count
    with (out / 'poses.csv').open('w', newline='') as handle:
        table = csv.writer(handle)
        table.writerow(POSE_COLUMNS)
        frames = tqdm(
            sequence,
            desc=f'tracking {sequence.name}',
            unit='frame',
            total=sequence.length,
            disable=not options.progress,
        )
        for frame in frames:
            truth.append(frame.ground_truth)
            for name, box in frame.ground_truths.items():
                tracks.setdefault(name, [None] * (len(truth) - 1)).append(box)
            if frame.image is None:
                # Counted, written as a row, and scored as a miss where annotated: never lost.
                rejected[frame.rejected] = rejected.get(frame.rejected, 0) + 1
                for name in names:
                    predicted[name].append(None)
                    estimated[name].append(None)
                    ids[name].append(0)
                table.writerow([frame.index, frame.stamp_ns, *[''] * 5, 'REJECTED', *[''] * _AFTER_STATUS])
                continue
            start, cpu = time.perf_counter(), time.process_time()
            if frame.index == 0 and options.init is not None:
                check_box_in_image(options.init, frame.image.shape)
                pipeline.start_from_box(options.init, init_kind)
            result = pipeline.process(Frame(frame.image, frame.stamp_ns))
            outcomes = result.outcomes
            if result.grey:
                # No colour, no skin: empty labels (a hand is started and held by its skin, so
                # none is followed: on grey frames one settled on blinds).
                if grey_frames == 0:
                    sequence.warnings.append(GREY_WARNING.format(name=sequence.name, index=frame.index))
                    _LOG.warning(sequence.warnings[-1])
                grey_frames += 1
            elapsed += time.perf_counter() - start
            busy += time.process_time() - cpu
            motion_set_aside += result.motion_set_aside
            ran = {outcome.name: outcome for outcome in outcomes}
            for name in names:
                outcome = ran.get(name)
                followed = outcome is not None and outcome.result.tracking
                predicted[name].append(outcome.result.estimate.box if followed else None)
                estimate = None if outcome is None else outcome.result.estimate
                estimated[name].append(None if estimate is None else estimate.box)
                if estimate is not None:
                    particles.append(estimate.particle_count)
                ids[name].append(outcome.id if outcome is not None else 0)
            gestures = {person: str(reading.gesture) for person, reading in result.gestures.items()}
            for outcome in outcomes:
                table.writerow(_pose_row(frame.index, frame.stamp_ns, outcome, gestures.get(outcome.person, '')))
            if options.video and frame.index % options.video_every == 0:
                label = ' '.join(
                    [f'{sequence.name} {frame.index}', *(g.replace('_', ' ') for g in gestures.values() if g)]
                )
                image = _annotated_frame(frame.image, outcomes, frame.ground_truth, label)
                if writer is None:
                    height, size = image.shape[:2]
                    writer = cv2.VideoWriter(
                        str(out / 'tracking.mp4'),
                        cv2.VideoWriter_fourcc(*'mp4v'),
                        sequence.fps / options.video_every,
                        (size, height),
                    )
                writer.write(image)
    if writer is not None:
        writer.release()
    processed = len(truth) - sum(rejected.values())
    # Scored: the one target, or the target that matches the ground truth best.
    scored = names[0]
    if len(names) > 1 and any(t is not None for t in truth):
        scored = max(names, key=lambda name: summarise(predicted[name], truth)['precision_20px'])
    summary: dict[str, object] = {
        'source': str(source),
        'target': target,
        'cue': pipeline.stages.motion_cue,
        'skin': pipeline.stages.skin is not None,
        'working_width': width,
        'frames_without_colour': grey_frames,
        'warnings': sequence.warnings,
        'frames_motion_set_aside': motion_set_aside,
        'background_restarts': motion.restarts if isinstance(motion := pipeline.stages.motion, BackgroundModel) else 0,
        'init': list(options.init) if options.init is not None else 'motion',
        'frames': len(truth),
        'frames_processed': processed,
        'frames_rejected': sum(rejected.values()),
        'rejected_reasons': rejected,
        'frames_tracked': int(sum(b is not None for b in predicted[scored])),
        'fps': round(processed / elapsed, 2) if elapsed > 0 else None,
        'ms_per_frame': round(1000 * elapsed / max(processed, 1), 3),
        'cpu_ms_per_frame': round(1000 * busy / max(processed, 1), 3),
        # The particle counts in use (KLD-sampling): least, median, most over every estimate.
        'particles': [int(np.min(particles)), int(np.median(particles)), int(np.max(particles))] if particles else [],
    }
    if len(names) > 1:
        summary['targets'] = {name: _id_summary(ids[name]) for name in names}
        summary['scored_kind'] = scored
    if any(t is not None for t in truth):
        summary.update(summarise(predicted[scored], truth, estimated[scored]))
        summary.update(identity_scores({'truth': truth}, one_track(ids[scored], predicted[scored])))
    if len(tracks) > 1:
        summary.update(_several_tracks(tracks, predicted, ids, kind_of))
    summary['plots'] = [p.name for p in plot_run(out, predicted[scored], truth, sequence.name)]
    (out / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
    return summary


def _frame_path(target: str, options: TrackOptions) -> FramePipeline:
    """The frame path of ``target`` with ``options``' cues and parameters."""
    kinds = kinds_of(target, options.hands)
    if len(kinds) > 1 and (options.template_file or options.target_parameters is not None):
        raise ValueError('a template file and target parameters are for one target, not a person')
    parameters = {kinds[0]: options.target_parameters} if options.target_parameters is not None else {}
    if options.working_width is not None:
        parameters = {
            k: replace(parameters.get(k) or parameters_for(k), working_width=options.working_width) for k in kinds
        }
    return FramePipeline.for_target(
        target,
        options.filter_parameters,
        parameters,
        cue=options.cue,
        skin=options.skin,
        skin_parameters=options.skin_parameters,
        hands=options.hands,
        max_people=options.max_people,
        template_file=options.template_file,
    )


def _several_tracks(
    tracks: dict[str, list[Box | None]],
    predicted: dict[str, list[Box | None]],
    ids: dict[str, list[int]],
    kind_of: dict[str, str],
) -> dict[str, object]:
    """Scores of a sequence with several ground-truth tracks (``person_1/head``, ...): each
    track's precision against the target of its kind (the last part of its name) that matches
    it best (``kind_of``: each target's kind, by name), and MOTA, IDF1 and identity switches of
    every target of an annotated kind against every track of its kind."""
    scores: dict[str, object] = {}
    for name, boxes in tracks.items():
        kind = name.rsplit('/', 1)[-1]
        precisions = [summarise(p, boxes)['precision_20px'] for slot, p in predicted.items() if kind_of[slot] == kind]
        if precisions:
            scores[name] = {'precision_20px': max(precisions)}
    # A kind without a ground-truth track (hands beside heads annotated alone) is not scored.
    annotated = {name.rsplit('/', 1)[-1] for name in tracks}
    scored = {name: boxes for name, boxes in predicted.items() if kind_of[name] in annotated}
    reported = [
        {ids[name][index]: box for name, boxes in scored.items() if (box := boxes[index]) is not None}
        for index in range(len(next(iter(predicted.values()))))
    ]
    kinds = {i: kind_of[name] for name in scored for i in ids[name] if i}
    return {'tracks': scores, 'all_tracks': identity_scores(tracks, reported, kinds=kinds)}


def _pose_row(index: int, stamp_ns: int, outcome: TrackedTarget, gesture: str = '') -> list[object]:
    """One target's row of ``poses.csv`` (:data:`POSE_COLUMNS`); ``gesture``: its person's."""
    result, estimate = outcome.result, outcome.result.estimate
    who = [outcome.id or '', outcome.kind, outcome.person, outcome.name, gesture]
    if estimate is None:
        return [index, stamp_ns, *[''] * 5, result.status, *[''] * (_AFTER_STATUS - len(who)), *who]
    x, y, s, theta = (round(float(v), 4) for v in estimate.state)
    shown = [round(v, 2) for v in estimate.box] if result.tracking else ['', '', '', '']
    support = (estimate.motion_support, estimate.skin_support, estimate.appearance_distance)
    (var_x, cov_xy), (_, var_y) = estimate.centre_covariance
    return [
        *(index, stamp_ns, x, y, s, theta, round(estimate.confidence, 4), result.status),
        *shown,
        estimate.shape,
        result.facing or '',
        *(round(v, 4) for v in support),
        *(round(float(v), 3) for v in (var_x, cov_xy, var_y)),
        *who,
    ]


def _annotated_frame(image: np.ndarray, outcomes: list[TrackedTarget], truth: Box | None, label: str) -> np.ndarray:
    """The frame with every target drawn: one target as :func:`annotate` draws it; several each
    in its id's colour, tagged with its kind and id."""
    first = outcomes[0].result
    detections = tuple(d for o in outcomes for d in o.result.detections)
    if len(outcomes) == 1:
        estimate = first.estimate
        return annotate(
            image,
            contour=None if estimate is None else estimate.contour,
            box=estimate.box if first.tracking else None,
            truth=truth,
            label=f'{label} {state_words(first)}',
            detections=detections,
        )
    shown = annotate(image, truth=truth, label=f'{label} {targets_line(outcomes)}', detections=detections)
    for outcome in outcomes:
        estimate = outcome.result.estimate
        if estimate is not None and outcome.result.tracking:
            draw_target(shown, outcome.id, f'{outcome.kind} {outcome.id}', estimate.contour, estimate.box)
    return shown


def _id_summary(ids: list[int]) -> dict[str, object]:
    """How a kind's ids went: how many were given, and the share of the frames the longest-held
    one was held."""
    held = [i for i in ids if i]
    longest = max((held.count(i) for i in set(held)), default=0)
    return {
        'ids': len(set(held)),
        'frames_tracked': len(held),
        'longest_id_share': round(longest / max(len(ids), 1), 4),
    }
