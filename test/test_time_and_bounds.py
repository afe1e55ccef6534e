"""Gaps in time and a missing motion stage, through the tracker node (real rclpy node objects)."""

from __future__ import annotations

import time

import numpy as np
import rclpy
from conftest import BAGS
from rclpy.parameter import Parameter

from human_tracker.evaluation.metrics import summarise
from human_tracker.io.bags import read_frames
from human_tracker.ros.image_conversion import array_to_image, message_to_bgr8, to_mono8
from human_tracker.ros.tracker_node import TrackerNode
from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.cues.optical_flow import OpticalFlow
from human_tracker.vision.filter.contour_filter import TrackerParameters
from human_tracker.vision.filter.templates import head_and_shoulders
from human_tracker.vision.track.target import TargetParameters, TargetTracker


def _header(message, seconds: float):
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(int(seconds * 1e9), 10**9)
    return message.header


def test_after_a_gap_motion_restarts_the_filter_where_the_person_now_is() -> None:
    """head_basic frames 0-30, then nothing for 5 s, then frames 70-100 (the person moved away)."""
    frames = list(read_frames(str(BAGS / 'head_basic')))
    images = [message_to_bgr8(f.message) for f in frames]
    rclpy.init()
    node = TrackerNode(subscribe_image=False)
    flow = OpticalFlow()
    results = {}
    try:
        for index in [*range(0, 31), *range(70, 100)]:
            mask = flow.apply(to_mono8(images[index]))[1]
            seconds = index / 30 + (5.0 if index >= 70 else 0.0)
            header = _header(array_to_image(images[index], 'bgr8'), seconds)
            results[index] = node.process_frame(images[index], header, evidence=Evidence(images[index], motion=mask))
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert results[30].status == 'TRACKING'
    restarted = [i for i in range(70, 100) if results[i].initialised]
    statuses = ''.join(results[i].status[0] for i in range(70, 100))
    print(f'after the 5 s gap: restarted from motion at frames {restarted}; statuses {statuses}')
    assert restarted and restarted[0] <= 70 + 15
    after = range(restarted[0] + 5, 100)
    boxes = [results[i].estimate.box if results[i].tracking else None for i in after]
    assert summarise(boxes, [frames[i].ground_truth for i in after])['precision_20px'] >= 0.9


def test_a_stall_of_the_node_s_own_is_not_reported_as_a_camera_gap() -> None:
    """Two gaps of 5 s between stamps: across the first the process computed (its own stall:
    the camera's frames were dropped meanwhile), across the second it idled (the camera
    paused). Only the first is counted as a stall; both mark the target lost."""
    images = [message_to_bgr8(f.message) for f in list(read_frames(str(BAGS / 'head_basic')))[:3]]
    rclpy.init()
    node = TrackerNode(subscribe_image=False)
    try:
        node.process_frame(images[0], _header(array_to_image(images[0], 'bgr8'), 0.0))
        deadline = time.process_time() + 0.4
        while time.process_time() < deadline:  # the node's own work, as a compilation would be
            pass
        node.process_frame(images[1], _header(array_to_image(images[1], 'bgr8'), 5.0))
        stalls_after_busy = node.gaps.stalls
        time.sleep(0.4)  # idle: the camera sent nothing
        node.process_frame(images[2], _header(array_to_image(images[2], 'bgr8'), 10.0))
        stalls_after_idle = node.gaps.stalls
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert (stalls_after_busy, stalls_after_idle) == (1, 1)


def test_frames_waiting_for_masks_that_never_come_stay_bounded_and_counted() -> None:
    frames = list(read_frames(str(BAGS / 'head_basic')))[:40]
    rclpy.init()
    overrides = [
        Parameter('motion_input', value='foreground'),
        Parameter('max_pending', value=5),
        Parameter('match_timeout', value=0.05),
    ]
    node = TrackerNode(parameter_overrides=overrides)
    most_pending = 0
    try:
        for index, frame in enumerate(frames):
            message = array_to_image(message_to_bgr8(frame.message), 'bgr8')
            _header(message, index / 30)
            node.on_image(message)
            most_pending = max(most_pending, len(node.inputs.matcher.held))
        deadline = time.monotonic() + 5.0
        while node.inputs.matcher.held and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert most_pending <= 5
    assert not node.inputs.matcher.held
    assert node.counters.processed == 40 and node.inputs.matcher.unmatched == {'foreground': 40}


def test_frames_that_never_reach_the_tracker_are_counted_from_their_masks() -> None:
    """Masks of frames 0-9 arrive; the images of 4 and 7 never do, and the mask of 8 comes late."""
    frames = list(read_frames(str(BAGS / 'head_basic')))[:10]
    rclpy.init()
    overrides = [Parameter('motion_input', value='foreground'), Parameter('match_timeout', value=0.05)]
    node = TrackerNode(parameter_overrides=overrides)

    def mask(index: int):
        message = array_to_image(np.zeros((240, 320), np.uint8), 'mono8')
        _header(message, index / 30)
        return message

    try:
        for index, frame in enumerate(frames):
            if index == 9:
                time.sleep(0.1)  # frame 8 waits out match_timeout and is tracked without its mask
            if index != 8:
                node.inputs.on_mask('foreground', mask(index))
            if index not in (4, 7):
                message = array_to_image(message_to_bgr8(frame.message), 'bgr8')
                _header(message, index / 30)
                node.on_image(message)
        node.inputs.on_mask('foreground', mask(8))  # after its frame was tracked: late, not lost
        diagnostics = node.diagnostics_state()[1]
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert node.counters.processed == 8 and node.inputs.matcher.unmatched == {'foreground': 1}
    assert diagnostics['frames_never_received'] == 2


def test_a_mask_of_another_frame_shape_is_counted_and_the_frame_tracked_without_it() -> None:
    """A mask at any resolution of the frame is used; one of another shape is rejected, counted."""
    frames = list(read_frames(str(BAGS / 'head_basic')))[:3]
    rclpy.init()
    node = TrackerNode(subscribe_image=False)
    results = []
    try:
        for index, motion in enumerate([np.zeros((120, 160), np.uint8), np.zeros((100, 100), np.uint8), None]):
            image = message_to_bgr8(frames[index].message)
            header = _header(array_to_image(image, 'bgr8'), index / 30)
            results.append(node.process_frame(image, header, evidence=Evidence(image, motion=motion)))
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert node.counters.processed == 3 and all(r is not None for r in results)
    assert node.counters.rejected_reasons == {'mask_size': 1}


def test_zero_and_negative_time_steps_do_not_break_the_core() -> None:
    """The core works per frame: repeated frames (dt = 0) are just more evidence."""
    tracker = TargetTracker(head_and_shoulders(), TrackerParameters(), TargetParameters())
    gray = np.zeros((120, 160), np.uint8)
    gray[40:80, 60:100] = 200
    tracker.initialise_from_box((60, 40, 40, 50))
    for _ in range(3):
        result = tracker.process(gray)
    assert np.all(np.isfinite(result.estimate.state))
