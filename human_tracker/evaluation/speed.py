"""Milliseconds per frame of each stage and of the whole per-frame pipeline, on real frames.

Every stage's figure is the median over the frames (after one warm-up frame, so numba's
compilation is not counted), measured in this process on this machine; a whole pipeline's, see
:func:`stage_timings`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import cv2
import numpy as np

from human_tracker.io.images import message_to_bgr8, to_mono8
from human_tracker.vision.cues.background import BackgroundModel
from human_tracker.vision.cues.edges import edge_map
from human_tracker.vision.cues.optical_flow import OpticalFlow
from human_tracker.vision.cues.skin import SkinSegmenter, default_skin_model
from human_tracker.vision.cues.stages import Frame
from human_tracker.vision.filter.contour_filter import ContourTracker, TrackerParameters
from human_tracker.vision.filter.templates import head_and_shoulders
from human_tracker.vision.frame_pipeline import FramePipeline
from human_tracker.vision.track.target import parameters_for

__all__ = ['PARTICLE_COUNTS', 'stage_timings']

PARTICLE_COUNTS = (250, 500, 1000, 2000)
# Passes over the frames of each whole pipeline, whose median is reported.
PIPELINE_PASSES = 5
# The stamps of the timed frames: a 30 Hz camera.
FRAME_INTERVAL_NS = 33_333_333


class _RawImage:
    """The fields of a raw bgr8 sensor_msgs/Image, for timing the conversion without ROS."""

    def __init__(self, image: np.ndarray) -> None:
        self.height, self.width = image.shape[:2]
        self.encoding, self.is_bigendian, self.step = 'bgr8', 0, image.shape[1] * 3
        self.data = image.tobytes()


def _ms_per_frame(run: Callable[[int], object], count: int) -> float:
    """Median wall-clock ms per frame, after one warm-up frame."""
    run(0)  # warm-up: JIT compilation, buffers
    times = []
    for index in range(1, count):
        start = time.perf_counter()
        run(index)
        times.append(time.perf_counter() - start)
    return 1000.0 * float(np.median(times))


def _wall_and_cpu_ms(run: Callable[[int], object], count: int) -> tuple[float, float]:
    """Mean wall-clock ms and mean CPU ms per frame, every thread of the process counted (the
    face detector's runs in its own), after one warm-up frame."""
    run(0)
    wall, cpu = time.perf_counter(), time.process_time()
    for index in range(1, count):
        run(index)
    frames = max(count - 1, 1)
    return 1000.0 * (time.perf_counter() - wall) / frames, 1000.0 * (time.process_time() - cpu) / frames


def stage_timings(
    frames: list[np.ndarray], boxes: list[tuple[float, float, float, float]], scale: float = 1.0
) -> dict[str, float]:
    """Median ms per frame of each stage on ``frames`` (BGR), resized by ``scale``.

    Stages: ``conversion`` (raw Image message to BGR and grey), ``edges``, ``colour_edges``,
    ``background``, ``flow``, ``skin`` (§3.2 segmentation), ``particle_filter_<P>`` (one
    predict-weigh-resample step with P particles), and the frame path the nodes and ``track``
    run (:class:`~human_tracker.vision.frame_pipeline.FramePipeline`, each with its target's
    default cues and 500 particles, after the message's conversion): ``pipeline`` (the head
    from the first box; ``pipeline_full_size``: the same at full size), ``hand_pipeline`` (the
    hand from the first box, with skin) and ``person_pipeline`` (a head from the first box
    and two hands starting by themselves), all on the same frames. A
    pipeline's figure is a mean over the frames, not a median (the face detector runs on one
    frame in ``detect_every``, and a median would leave it out): the median of
    ``PIPELINE_PASSES`` such means; ``<pipeline>_cpu`` is the CPU time of every thread of the
    process per frame, the face detector's thread included.
    """
    if scale != 1.0:
        frames = [cv2.resize(f, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) for f in frames]
        boxes = [tuple(v * scale for v in b) for b in boxes]
    messages = [_RawImage(f) for f in frames]
    grays = [to_mono8(f) for f in frames]
    edges = [edge_map(g) for g in grays]
    template = head_and_shoulders()
    count = len(frames)
    results: dict[str, float] = {}
    results['conversion'] = _ms_per_frame(lambda i: to_mono8(message_to_bgr8(messages[i])), count)
    results['edges'] = _ms_per_frame(lambda i: edge_map(grays[i]), count)
    results['colour_edges'] = _ms_per_frame(lambda i: edge_map(frames[i]), count)
    background = BackgroundModel()
    results['background'] = _ms_per_frame(lambda i: background.apply(grays[i]), count)
    flow = OpticalFlow()
    results['flow'] = _ms_per_frame(lambda i: flow.apply(grays[i]), count)
    segmenter = SkinSegmenter(default_skin_model())
    results['skin'] = _ms_per_frame(lambda i: segmenter.segment(frames[i]), count)
    for particles in PARTICLE_COUNTS:
        tracker = ContourTracker(template, TrackerParameters(num_particles=particles, min_scale=24.0 * scale))
        tracker.initialise_from_box(boxes[0])
        results[f'particle_filter_{particles}'] = _ms_per_frame(lambda i, t=tracker: t.step(edges[i]), count)
    filter_parameters = TrackerParameters(num_particles=500, min_scale=24.0 * scale)
    full_size = {'head': replace(parameters_for('head'), working_width=0)}

    def frame_path(target: str, **options: object) -> Callable[[int], object]:
        pipeline = FramePipeline.for_target(target, filter_parameters, **options)
        pipeline.start_from_box(boxes[0])
        return _timed_frames(messages, pipeline)

    pipelines: dict[str, Callable[[], Callable[[int], object]]] = {
        'pipeline': lambda: frame_path('head'),
        'pipeline_full_size': lambda: frame_path('head', parameters=full_size),
        'hand_pipeline': lambda: frame_path('hand'),
        'person_pipeline': lambda: frame_path('person', hands=2),
    }
    # Each pipeline afresh on the frames, the pipelines in turn, PIPELINE_PASSES times: the
    # median pass of each. One pass each moved the person's cost against the head's by a
    # fifth between runs of the same code (the face detector's thread, the machine's load).
    passes: dict[str, list[tuple[float, float]]] = {name: [] for name in pipelines}
    for _ in range(PIPELINE_PASSES):
        for name, make in pipelines.items():
            passes[name].append(_wall_and_cpu_ms(make(), count))
    for name, measured in passes.items():
        results[name], results[f'{name}_cpu'] = (float(np.median(column)) for column in zip(*measured, strict=True))
    return {k: round(v, 3) for k, v in results.items()}


def _timed_frames(messages: list[_RawImage], pipeline: FramePipeline) -> Callable[[int], object]:
    """One frame as the ``pipeline`` node runs it: the message converted, then the frame path
    (every cue stage and tracker of ``pipeline``), stamped at 30 Hz."""

    def run(i: int) -> object:
        return pipeline.process(Frame(message_to_bgr8(messages[i]), i * FRAME_INTERVAL_NS))

    return run
