"""Milliseconds per frame of each stage and of the whole per-frame pipeline, on real frames.

Every stage's figure is the median over the frames (after one warm-up frame, so numba's
compilation is not counted), measured in this process on this machine; a whole pipeline's, see
:func:`stage_timings`.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import cv2
import numpy as np

from human_tracker.io.images import message_to_bgr8, to_mono8
from human_tracker.vision.background import BackgroundModel
from human_tracker.vision.edges import edge_map
from human_tracker.vision.optical_flow import OpticalFlow
from human_tracker.vision.people import PersonTracker
from human_tracker.vision.resolution import to_working, working_scale
from human_tracker.vision.skin import SkinSegmenter, default_skin_model
from human_tracker.vision.target import TargetParameters, TargetTracker, parameters_for
from human_tracker.vision.templates import hand, head_and_shoulders
from human_tracker.vision.tracker import ContourTracker, TrackerParameters

__all__ = ['PARTICLE_COUNTS', 'stage_timings']

PARTICLE_COUNTS = (250, 500, 1000, 2000)
# Passes over the frames of each whole pipeline, whose median is reported.
PIPELINE_PASSES = 5


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
    predict-weigh-resample step with P particles), ``pipeline`` (conversion + edges +
    background + flow + the head tracker with 500 particles, motion-weighted, all at the
    default working width; ``pipeline_full_size``: the same at full size) and
    ``hand_pipeline`` (conversion + background + skin + the hand tracker: colour edges and
    the colour term, at the working width) and ``person_pipeline`` (the same cues, a head's
    tracker from the first box and two hands' starting by themselves, the second while the
    first is followed, :mod:`~human_tracker.vision.people`), all on the same frames. A
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
    hand_width = parameters_for('hand').working_width

    def hand_process() -> Callable[..., object]:
        tracker = TargetTracker(hand(), filter_parameters, parameters_for('hand'))
        tracker.initialise_from_box(boxes[0])
        return tracker.process

    def person_process() -> Callable[..., object]:
        person = PersonTracker(('head', 'hand', 'hand'), filter_parameters)
        person.initialise_from_box(boxes[0], 'head')
        return person.process

    pipelines: dict[str, Callable[[], Callable[[int], object]]] = {
        'pipeline': lambda: _pipeline(messages, boxes[0], filter_parameters, TargetParameters().working_width),
        'pipeline_full_size': lambda: _pipeline(messages, boxes[0], filter_parameters, 0),
        'hand_pipeline': lambda: _skin_pipeline(messages, hand_process(), segmenter, hand_width),
        'person_pipeline': lambda: _skin_pipeline(messages, person_process(), segmenter, hand_width),
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


def _skin_pipeline(
    messages: list[_RawImage], process: Callable[..., object], segmenter: SkinSegmenter, working_width: int
) -> Callable[[int], object]:
    """One frame of a pipeline with skin (a hand's, a person's): conversion, the background cue
    and the skin labels at ``working_width``, then ``process(image, motion, skin)``."""
    cue = BackgroundModel()

    def run(i: int) -> object:
        image = message_to_bgr8(messages[i])
        working = to_working(image, working_width)
        skin = segmenter.segment(working, working_scale(image.shape[1], working_width))
        mask = cue.apply(to_mono8(working))
        return process(image, mask, skin, camera_motion=cue.camera_motion_in(image.shape[1]))

    return run


def _pipeline(
    messages: list[_RawImage], box: tuple[float, float, float, float], parameters: TrackerParameters, working_width: int
) -> Callable[[int], object]:
    """One frame of the head pipeline as the ``pipeline`` node runs it by default (background
    cue; the tracker's appearance term, face proposals and camera compensation), at ``working_width``."""
    target = TargetTracker(head_and_shoulders(), parameters, TargetParameters(working_width=working_width))
    target.initialise_from_box(box)
    cue = BackgroundModel()

    def run(i: int) -> object:
        image = message_to_bgr8(messages[i])
        mask = cue.apply(to_working(to_mono8(image), working_width))
        # Colour: the appearance term's histograms.
        return target.process(image, mask, camera_motion=cue.camera_motion_in(image.shape[1]))

    return run
