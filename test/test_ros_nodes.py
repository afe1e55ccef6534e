"""The nodes over real rclpy / Fast DDS, in separate OS processes, driven by bag replay."""

from __future__ import annotations

import csv
import dataclasses
import re
import signal
import time
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
import pytest
import rclpy
from conftest import REPO
from hri_msgs.msg import Gesture as GestureMessage
from hri_msgs.msg import IdsMatch
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from ros_harness import collecting, environment, replay_and_collect
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import RegionOfInterest
from std_srvs.srv import Trigger
from test_target import track

from human_tracker.demo import node_arguments
from human_tracker.evaluation.identity import identity_scores
from human_tracker.evaluation.metrics import summarise
from human_tracker.io.bags import (
    CAMERA_FRAME,
    CAMERA_TOPIC,
    COMPRESSED_CAMERA_TOPIC,
    DEPTH_TOPIC,
    read_frames,
    write_scene_bag,
)
from human_tracker.io.images import message_to_bgr8, stamp_ns
from human_tracker.io.poses import read_poses, read_tracks
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.ros.collector import PoseCollector
from human_tracker.ros.processes import NodeProcess
from human_tracker.ros.standard_outputs import frame_name, gaze_frame_name, target_name
from human_tracker.scenes.generator import HEAD_WIDTH, SCENES, render_scene
from human_tracker.vision.filter.contour_filter import box_from_state
from human_tracker.vision.filter.templates import ContourTemplate, fit_template, hand, head_and_shoulders
from human_tracker.vision.geometry.boxes import box_centre
from human_tracker.vision.geometry.camera import back_project, default_camera_matrix, metric_positions
from human_tracker.vision.people.gestures import Gesture


def _pixel(position, camera_matrix: np.ndarray) -> tuple[float, float]:
    """Where a position in the optical frame (metres) projects in the image, pixels."""
    k = camera_matrix
    return k[0, 0] * position.x / position.z + k[0, 2], k[1, 1] * position.y / position.z + k[1, 2]


def _boxes(collector, frames, template: ContourTemplate | None = None) -> list:
    """The reference boxes of the published contours, by frame (None where none was published):
    a contour is the template in one of its shapes (a hand open or closed), the one it fits."""
    template = template or head_and_shoulders()
    boxes = []
    for frame in frames:
        contour = collector.contours.get(frame.stamp_ns)
        boxes.append(None if contour is None else box_from_state(fit_template(template, contour)[0], template))
    return boxes


def test_bag_play_and_tracker_node_in_separate_processes(head_bag, tmp_path) -> None:
    frames = list(read_frames(head_bag))
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        node_arguments(COMPRESSED_CAMERA_TOPIC, True, frames[0].ground_truth),
        environment(),
        tmp_path / 'tracker.log',
    )
    collector = replay_and_collect(tracker, head_bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames))
    # A pose for every frame, stamped with that frame's stamp, in the camera's optical frame.
    assert sorted(collector.poses) == [f.stamp_ns for f in frames]
    assert collector.frame_ids == {'camera_optical_frame'}
    summary = summarise(_boxes(collector, frames), [f.ground_truth for f in frames])
    print(f'tracker_node over DDS: {summary}')
    assert summary['precision_20px'] >= 0.9
    # Depth from scale: the true head is ground-truth-box wide; 0.16 m at the bag's 60° camera.
    focal = default_camera_matrix(640, 480)[0, 0]
    relative = [
        abs(collector.poses[f.stamp_ns].pose.pose.position.z / (focal * 0.16 / f.ground_truth[2]) - 1) for f in frames
    ]
    assert np.median(relative) < 0.1
    covariance = np.array(collector.poses[frames[-1].stamp_ns].pose.covariance).reshape(6, 6)
    assert np.all(np.diag(covariance) > 0)
    # Velocity: the ground truth's metric centre differentiated, against the AR(2) state's.
    truth = []  # the ground truth's metric centres
    for frame in frames:
        x, y, w, h = frame.ground_truth
        truth.append(
            back_project(np.array([[x + w / 2, y + h / 2]]), focal * 0.16 / w, default_camera_matrix(640, 480))[0]
        )
    stamps = np.array([f.stamp_ns for f in frames]) / 1e9
    true_velocity = (np.diff(truth, axis=0) / np.diff(stamps)[:, None])[:, :2]
    twists = [collector.velocities[f.stamp_ns].twist for f in frames[1:]]  # none on the first frame
    assert frames[0].stamp_ns not in collector.velocities
    velocity = np.array([[t.twist.linear.x, t.twist.linear.y] for t in twists])
    spread = np.sqrt([np.diag(np.reshape(t.covariance, (6, 6)))[:2] for t in twists])
    print(f'velocity error (m/s): median {np.median(np.abs(velocity - true_velocity), axis=0)}')
    # The pose's covariance holds the contour's own error and, along the ray, the distance's
    # from an assumed width: the normalised error squared near its expected 2 (6.9 with the
    # distance's error along the optical axis, 4.4 without the width's spread).
    errors = [
        np.subtract([p.pose.position.x, p.pose.position.y], t[:2])
        for p, t in ((collector.poses[f.stamp_ns].pose, t) for f, t in zip(frames, truth, strict=True))
    ]
    covariances = [np.reshape(collector.poses[f.stamp_ns].pose.covariance, (6, 6))[:2, :2] for f in frames]
    nees = np.mean([e @ np.linalg.solve(c, e) for e, c in zip(errors, covariances, strict=True)])
    print(f'pose NEES (x, y; 2 expected): {nees:.2f}')
    assert 1.0 < nees < 4.0
    assert np.all(np.median(np.abs(velocity - true_velocity), axis=0) < 0.1)  # the head moves at ~0.4 m/s
    assert np.corrcoef(velocity[:, 0], true_velocity[:, 0])[0, 1] > 0.8
    # The covariance is the cloud's: errors about one standard deviation (0.5 and 0.75 measured).
    normalised = np.mean(((velocity - true_velocity) / spread) ** 2, axis=0)
    assert np.all((normalised > 0.1) & (normalised < 4.0)), normalised


def test_markers_for_rviz_follow_the_contour_at_the_pose_depth(head_bag, tmp_path) -> None:
    """pipeline -> ``markers``: for every frame a closed line strip in the optical frame at the
    pose's depth that projects back onto the published contour, and a label above it."""
    frames = list(read_frames(head_bag))
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, frames[0].ground_truth)
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(pipeline, head_bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames), markers=True)
    assert sorted(collector.markers) == sorted(collector.poses) == [f.stamp_ns for f in frames]
    k = default_camera_matrix(640, 480)
    for stamp, array in collector.markers.items():
        strip, label = array.markers
        assert {strip.header.frame_id, label.header.frame_id} == {'camera_optical_frame'}
        assert (strip.ns, strip.id, strip.type, label.id, label.type) == ('human_tracker/head', 0, 4, 1, 9)
        assert re.fullmatch(r'head 0 TRACKING (toward|side|away|unknown)', label.text), label.text
        assert label.scale.z > 0 and strip.scale.x > 0
        assert strip.color.a == label.color.a == 1.0 and strip.lifetime.nanosec > 0
        points = np.array([[p.x, p.y, p.z] for p in strip.points])
        np.testing.assert_allclose(points[0], points[-1])  # closed
        np.testing.assert_allclose(points[:, 2], collector.poses[stamp].pose.pose.position.z)
        pixels = (k @ (points[:-1] / points[:-1, 2:]).T).T[:, :2]
        np.testing.assert_allclose(pixels, collector.contours[stamp], atol=1e-3)
        assert label.pose.position.y < points[:, 1].min()  # above the contour: y points down


def test_pipeline_on_raw_640x480_frames(tmp_path) -> None:
    """Raw bgr8 frames of 900 KB between processes (needs the 16 MB shared-memory profile)."""
    spec = dataclasses.replace(SCENES['head_basic'], name='raw', num_frames=30)
    bag = write_scene_bag(spec, tmp_path / 'raw_bag', compressed=False, storage='sqlite3')
    frames = list(read_frames(bag))
    args = node_arguments(CAMERA_TOPIC, False, frames[0].ground_truth)
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(pipeline, bag, CAMERA_TOPIC, tmp_path, len(frames))
    assert sorted(collector.poses) == [f.stamp_ns for f in frames]
    assert summarise(_boxes(collector, frames), [f.ground_truth for f in frames])['precision_20px'] >= 0.9


@pytest.mark.parametrize(
    ('bag_name', 'stage', 'motion_input', 'cue'),
    [
        ('head_cluttered', 'background_node', 'foreground', 'background'),
        ('head_leave_return', 'optical_flow_node', 'motion', 'flow'),
    ],
)
def test_motion_stage_and_tracker_in_separate_processes(
    tmp_path, bag_name: str, stage: str, motion_input: str, cue: str
) -> None:
    """bag_play -> background_node or optical_flow_node -> tracker_node, masks matched by exact stamp.

    Started from motion alone, the nodes must publish exactly what the ROS-free core computes
    on the same frames: a pose on the same frames, at the same place.
    """
    bag = REPO / 'bags' / bag_name
    frames = list(read_frames(bag))
    env = environment()
    motion = NodeProcess(
        f'human_tracker.ros.{stage}', node_arguments(COMPRESSED_CAMERA_TOPIC, True), env, tmp_path / 'stage.log'
    )
    # A long match timeout and a deep queue: on a loaded machine a late mask must still be
    # waited for, since this test compares every frame with the core.
    tracker_args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, motion_input=motion_input)
    tracker_args += ['-p', 'match_timeout:=5.0', '-p', 'max_pending:=500']
    tracker = NodeProcess('human_tracker.ros.tracker_node', tracker_args, env, tmp_path / 'tracker.log')
    collector = replay_and_collect(
        [motion, tracker], bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames), diagnostics_of='/tracker_node'
    )
    diagnostics = collector.diagnostics.get('/tracker_node', {})
    offline = track(bag_name, cue)
    over_dds = _boxes(collector, frames)
    summary = summarise(over_dds, [f.ground_truth for f in frames])
    print(f'{stage} -> tracker_node on {bag_name}: {len(collector.poses)} poses for {len(frames)} frames; {summary}')
    print(f'tracker_node diagnostics: {diagnostics}')
    assert diagnostics.get('frames_processed') == str(len(frames))
    assert diagnostics.get(f'frames_without_{motion_input}') == '0'
    assert diagnostics.get('frames_motion_set_aside') == '0'  # a fixed camera: every mask is used
    assert [box is not None for box in over_dds] == [box is not None for box in offline.boxes]
    for dds_box, core_box in zip(over_dds, offline.boxes, strict=True):
        if core_box is not None:
            np.testing.assert_allclose(dds_box, core_box, atol=1e-3)
    # The latched status told every change of state the core went through, in order.
    changes = [s for k, s in enumerate(offline.statuses) if k == 0 or s != offline.statuses[k - 1]]
    assert collector.states() == (changes if changes[0] == 'WAITING' else ['WAITING', *changes])
    if bag_name == 'head_leave_return':
        assert collector.states()[:4] == ['WAITING', 'TRACKING', 'LOST', 'TRACKING']


def test_hand_chain_with_skin_node_in_separate_processes(tmp_path) -> None:
    """bag_play -> background_node + skin_node -> tracker_node (target hand), both masks matched by stamp.

    Started with no box, the nodes must publish what the offline command computes on the same
    frames, and follow the hand.
    """
    bag = REPO / 'bags' / 'hand_cluttered'
    frames = list(read_frames(bag))
    env = environment()
    stages = [
        NodeProcess(
            f'human_tracker.ros.{stage}', node_arguments(COMPRESSED_CAMERA_TOPIC, True), env, tmp_path / f'{stage}.log'
        )
        for stage in ('background_node', 'skin_node')
    ]
    tracker_args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, motion_input='foreground')
    tracker_args += ['-p', 'target:=hand', '-p', 'skin_input:=true', '-p', 'match_timeout:=5.0']
    tracker_args += ['-p', 'max_pending:=500']
    tracker = NodeProcess('human_tracker.ros.tracker_node', tracker_args, env, tmp_path / 'tracker.log')
    collector = replay_and_collect(
        [*stages, tracker], bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames), diagnostics_of='/tracker_node'
    )
    diagnostics = collector.diagnostics.get('/tracker_node', {})
    assert diagnostics.get('frames_processed') == str(len(frames))
    assert diagnostics.get('frames_without_foreground') == diagnostics.get('frames_without_skin') == '0'
    assert float(diagnostics['skin_support']) > 0.7  # the contour's interior is on the hand's skin
    assert diagnostics['shape'] in ('open_hand', 'closed_hand')
    offline = track_sequence(bag, tmp_path / 'offline', TrackOptions(target='hand', video=False, progress=False))
    core = read_poses(tmp_path / 'offline' / 'poses.csv')
    over_dds = _boxes(collector, frames, hand())
    summary = summarise(over_dds, [f.ground_truth for f in frames])
    print(f'hand over DDS: {summary}; offline: {offline["precision_20px"]}')
    assert summary['precision_20px'] >= 0.85  # LOST for frames 96-107 (test_hand_tracking.py)
    assert [box is not None for box in over_dds] == [box is not None for box in core]
    for dds_box, core_box in zip(over_dds, core, strict=True):
        if core_box is not None:
            np.testing.assert_allclose(dds_box, core_box, atol=0.05)  # poses.csv rounds to 0.01 px


def test_a_tracker_fed_masks_says_ready_once_their_publisher_is_matched(tmp_path) -> None:
    """A mask published before the tracker's subscription matched its publisher is lost, so
    the tracker holds its ``ready`` until then: not while no background node runs, soon after
    one starts."""
    env = environment()
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        node_arguments(COMPRESSED_CAMERA_TOPIC, True, motion_input='foreground'),
        env,
        tmp_path / 'tracker.log',
    )
    background = NodeProcess(
        'human_tracker.ros.background_node', node_arguments(COMPRESSED_CAMERA_TOPIC, True), env, tmp_path / 'bg.log'
    )
    with collecting() as (collector, executor):
        try:
            tracker.start()
            deadline = time.monotonic() + 60.0
            while 'warmed up in' not in tracker.output() and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            assert collector.spin_until_diagnostics(executor, '/tracker_node', 10.0).get('ready') == 'False'
            background.start()
            deadline = time.monotonic() + 60.0
            while collector.diagnostics.get('/tracker_node', {}).get('ready') != 'True':
                assert time.monotonic() < deadline, tracker.output()
                executor.spin_once(timeout_sec=0.05)
        finally:
            codes = [tracker.stop(), background.stop()]
    assert codes == [0, 0], tracker.output() + background.output()
    assert 'without a publisher' not in tracker.output()


def test_pipeline_follows_a_hand_with_the_skin_stage_in_process(tmp_path) -> None:
    """target:=hand turns the pipeline's skin stage on; the hand is found and followed."""
    bag = REPO / 'bags' / 'hand_wave'
    frames = list(read_frames(bag))
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True) + ['-p', 'target:=hand']
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(pipeline, bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames))
    assert 'configured: skin segmentation' in pipeline.output()
    summary = summarise(_boxes(collector, frames, hand()), [f.ground_truth for f in frames])
    print(f'pipeline, target hand: {summary}')
    assert summary['precision_20px'] >= 0.9


def test_a_person_pipeline_names_each_target_on_targets(tmp_path) -> None:
    """target:=person: each tracked target on ``targets`` as ``person_1/<kind>_<id>``, ids never
    shared between kinds; the hand's positions are the offline command's and follow the hand."""
    bag = REPO / 'bags' / 'hand_wave'
    frames = list(read_frames(bag))
    # A queue that holds the whole bag: two trackers a frame on a busy machine fall behind the
    # replay, and past the default 100 queued frames the oldest were dropped (frame 17 once).
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, depth=2 * len(frames)) + ['-p', 'target:=person']
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(
        pipeline, bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames), diagnostics_of='/tracker_node'
    )
    assert collector.diagnostics['/tracker_node']['frames_processed'] == str(len(frames))
    assert 'configured: skin segmentation' in pipeline.output()
    ids: dict[str, set[int]] = {'head': set(), 'hand': set()}
    hand: list[tuple[float, float] | None] = []
    height, width = message_to_bgr8(frames[0].message).shape[:2]
    k = default_camera_matrix(width, height)
    for frame in frames:
        centre = None
        for odometry in collector.targets.get(frame.stamp_ns, []):
            assert odometry.header.frame_id == CAMERA_FRAME
            person, kind, ident = _target_of(odometry)
            assert person == 'person_1' and ident > 0
            ids[kind].add(ident)
            if kind == 'hand':
                centre = _pixel(odometry.pose.pose.position, k)
        hand.append(centre)
    assert ids['hand'] and not ids['head'] & ids['hand']
    listed = collector.diagnostics['/tracker_node']['targets']  # the last frame's
    assert re.fullmatch(r'head (\d+|-) [A-Z]+( (toward|side|away|unknown))?, hand (\d+|-) [A-Z]+', listed), listed
    track_sequence(bag, tmp_path / 'offline', TrackOptions(target='person', video=False, progress=False))
    offline = read_tracks(tmp_path / 'offline' / 'poses.csv')['hand']
    assert [c is not None for c in hand] == [b is not None for b in offline]
    near = 0
    for centre, box, frame in zip(hand, offline, frames, strict=True):
        if centre is not None:
            np.testing.assert_allclose(centre, (box[0] + box[2] / 2, box[1] + box[3] / 2), atol=0.05)
            gx, gy, gw, gh = frame.ground_truth
            near += np.hypot(centre[0] - gx - gw / 2, centre[1] - gy - gh / 2) <= 20.0
    print(f'person over DDS: ids {ids}, hand within 20 px on {near} of {len(frames)} frames')
    assert near >= 0.9 * len(frames)


def test_two_people_over_dds_are_the_offline_commands(tmp_path) -> None:
    """people_crossing with max_people:=2: each person's head on ``targets`` under one id, at the
    offline command's positions, and following its own person's ground truth; the waving hand
    within 20 px of its ground truth on 90 % of the frames it is in view; every target (the
    heads and the hand) kept under its id: no identity switch, IDF1 at least 0.9. ``pose`` is
    the head's nearest the image's centre (``primary_id`` 0), the walker's while they pass it."""
    bag = REPO / 'bags' / 'people_crossing'
    frames = list(read_frames(bag))
    # Half the camera's rate, and a queue that holds the whole bag: three trackers a frame
    # fall behind a faster replay, and on a busy machine, past the default 100 queued frames,
    # the oldest were dropped.
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, depth=2 * len(frames))
    args += ['-p', 'target:=person', '-p', 'max_people:=2']
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(
        pipeline,
        bag,
        COMPRESSED_CAMERA_TOPIC,
        tmp_path,
        len(frames),
        rate=0.5,
        diagnostics_of='/tracker_node',
        standard=True,
    )
    assert collector.diagnostics['/tracker_node']['frames_processed'] == str(len(frames))
    height, width = message_to_bgr8(frames[0].message).shape[:2]
    k = default_camera_matrix(width, height)
    heads: dict[str, list[tuple[float, float] | None]] = {'person_1': [], 'person_2': []}
    ids: dict[str, set[int]] = {'person_1': set(), 'person_2': set()}
    reported: list[dict[int, tuple[float, float, float, float]]] = []
    hand_near = hand_in_view = 0
    primary = {'person_1': 0, 'person_2': 0}
    for frame in frames:
        seen: dict[str, tuple[float, float]] = {}
        positions: dict[str, Any] = {}
        reported.append({})
        hand_truth = frame.ground_truths['person_1/hand']
        hand_in_view += hand_truth is not None
        hand_found = False
        for odometry in collector.targets.get(frame.stamp_ns, []):
            person, kind, ident = _target_of(odometry)
            centre = _pixel(odometry.pose.pose.position, k)
            reported[-1][ident] = (*centre, 0.0, 0.0)
            if kind == 'head':
                seen[person] = centre
                positions[person] = odometry.pose.pose.position
                ids[person].add(int(ident))
            elif person == 'person_1' and hand_truth is not None:
                hand_found |= bool(np.hypot(*np.subtract(centre, box_centre(hand_truth))) <= 20.0)
        hand_near += hand_found
        for person in heads:
            heads[person].append(seen.get(person))
        pose = collector.poses.get(frame.stamp_ns)
        assert (pose is None) == (not seen)
        if seen:
            # The choice reads the boxes reported, these are the contours' head boxes: a near tie
            # may go either way.
            on = [p for p in positions if _same_point(positions[p], pose.pose.pose.position)]
            assert len(on) == 1
            primary[on[0]] += 1
            distances = {p: np.hypot(c[0] - width / 2, c[1] - height / 2) for p, c in seen.items()}
            if len(distances) == 2 and abs(distances['person_1'] - distances['person_2']) > 20.0:
                assert on[0] == min(distances, key=distances.get)
    assert len(ids['person_1']) == len(ids['person_2']) == 1 and not ids['person_1'] & ids['person_2']
    print(f'pose: the head of person_1 on {primary["person_1"]} frames, of person_2 on {primary["person_2"]}')
    assert primary['person_2'] > 0
    print(f'person_1/hand over DDS: within 20 px of its truth on {hand_near} of its {hand_in_view} frames in view')
    assert hand_near >= 0.9 * hand_in_view
    truth = {name: [frame.ground_truths[name] for frame in frames] for name in frames[0].ground_truths}
    identity = identity_scores(truth, reported)
    print('every target over DDS:', identity)
    assert identity['id_switches'] == 0 and identity['idf1'] >= 0.9
    track_sequence(bag, tmp_path / 'offline', TrackOptions(max_people=2, video=False, progress=False))
    rows = list(csv.DictReader((tmp_path / 'offline' / 'poses.csv').open()))
    template = head_and_shoulders()
    for person, slot in (('person_1', 'head'), ('person_2', 'person_2/head')):
        # The pose is the centre of the contour's head box, not of the box reported (placed by the face).
        # A person's rows begin on the frame its slot opens.
        by_frame = {
            int(r['frame']): box_centre(
                box_from_state(np.array([float(r[c]) for c in ('x', 'y', 'scale', 'theta')]), template)
            )
            for r in rows
            if r['target'] == slot and r['status'] == 'TRACKING'
        }
        offline = [by_frame.get(index) for index in range(len(frames))]
        assert [c is not None for c in heads[person]] == [c is not None for c in offline]
        near = in_view = 0
        for centre, expected, frame in zip(heads[person], offline, frames, strict=True):
            truth = frame.ground_truths[f'{person}/head']
            in_view += truth is not None
            if centre is not None:
                np.testing.assert_allclose(centre, expected, atol=0.05)
                near += truth is not None and np.hypot(*np.subtract(centre, box_centre(truth))) <= 20.0
        print(f'{person}/head over DDS: within 20 px of its truth on {near} of its {in_view} frames in view')
        assert near >= 0.9 * in_view
    _check_standard_outputs(collector, frames, rows, (height, width))


def _target_of(odometry: Odometry) -> tuple[str, str, int]:
    """The person, kind and id a ``targets`` message names (``person_1/hand_2``)."""
    person, name = odometry.child_frame_id.split('/')
    kind, ident = name.split('_')
    return person, kind, int(ident)


def _lookup(transforms: list[Any], target: str, source: str) -> tuple[np.ndarray, Rotation]:
    """tf2's lookup on one stamp's transforms: ``source``'s origin and axes in ``target``, along
    the chain of parents from ``source`` up to ``target``."""
    parent_of = {t.child_frame_id: t for t in transforms}
    position, axes = np.zeros(3), Rotation.identity()
    frame = source
    while frame != target:
        link = parent_of[frame].transform  # KeyError: no chain to the target
        turn = Rotation.from_quat([link.rotation.x, link.rotation.y, link.rotation.z, link.rotation.w])
        position = turn.apply(position) + [link.translation.x, link.translation.y, link.translation.z]
        axes = turn * axes
        frame = parent_of[frame].header.frame_id
    return position, axes


def _check_standard_outputs(
    collector: PoseCollector, frames: list[Any], rows: list[dict[str, str]], shape: tuple[int, int]
) -> None:
    """What the people_crossing pipeline published on the standard outputs, as their consumers
    read it: each TRACKING target of ``targets`` has a TF frame whose tf2 lookup is its pose (to
    1 mm), a head's with a REP-155 gaze frame at its origin looking along the face frame's x (its
    z), and the same id on ``detections`` and ``detections_3d`` (the 3-D detection at its pose);
    a ROS4HRI client sees each head's face id listed from its third frame TRACKING in a row to
    its last, each region it gets the offline command's box of that head on that frame (within
    the image)."""
    height, width = shape
    boxes = {
        (int(r['frame']), int(r['id'])): [float(r[c]) for c in ('box_x', 'box_y', 'box_w', 'box_h')]
        for r in rows
        if r['kind'] == 'head' and r['status'] == 'TRACKING'
    }
    listed = {stamp_ns(m.header): set(m.ids) for m in collector.tracked}
    heads_before: list[set[int]] = []
    regions = 0
    for index, frame in enumerate(frames):
        stamp = frame.stamp_ns
        targets = {_target_of(o)[1:]: o for o in collector.targets.get(stamp, [])}
        detections = {d.id: d for d in collector.detections[stamp].detections}
        metric = {d.id: d for d in collector.detections_3d[stamp].detections}
        assert set(detections) == set(metric) == {target_name(kind, ident) for kind, ident in targets}
        for (kind, ident), odometry in targets.items():
            name = target_name(kind, ident)
            classes = {found[name].results[0].hypothesis.class_id for found in (detections, metric)}
            assert classes == {kind}
            expected = odometry.pose.pose.position
            assert _same_point(metric[name].results[0].pose.pose.position, expected)
            optical = odometry.header.frame_id
            position, axes = _lookup(collector.transforms[stamp], optical, frame_name(kind, ident))
            np.testing.assert_allclose(position, (expected.x, expected.y, expected.z), atol=1e-3)
            if kind == 'head':
                gaze_at, gaze = _lookup(collector.transforms[stamp], optical, gaze_frame_name(ident))
                np.testing.assert_allclose(gaze_at, position, atol=1e-9)
                np.testing.assert_allclose(gaze.apply([0, 0, 1]), axes.apply([1, 0, 0]), atol=1e-9)
                np.testing.assert_allclose(gaze.apply([1, 0, 0]), axes.apply([0, -1, 0]), atol=1e-9)
        heads = {ident for kind, ident in targets if kind == 'head'}
        heads_before.append(heads)
        # Listed on the frames it has been TRACKING for the last face_confirm_frames (3) in a row.
        confirmed = set.intersection(*heads_before[-3:]) if index >= 2 else set()
        assert listed[stamp] == {target_name('head', ident) for ident in confirmed}, index
        for ident in confirmed:
            region = collector.regions[target_name('head', ident)].get(stamp)
            if region is not None:
                regions += 1
                x, y, w, h = boxes[index, ident]
                corners = (region.xmin * width, region.ymin * height, region.xmax * width, region.ymax * height)
                inside = np.clip((x, y, x + w, y + h), 0.0, (width, height, width, height))
                np.testing.assert_allclose(corners, inside, atol=0.02)
    print(f'standard outputs: {len(collector.tracked)} face lists, {regions} face regions as the offline boxes')
    assert regions >= 0.9 * sum(len(heads) for heads in heads_before[2:]) - 5
    _check_bodies(collector, frames, rows)


def _check_bodies(collector: PoseCollector, frames: list[Any], rows: list[dict[str, str]]) -> set[str]:
    """ROS4HRI bodies, as a client reads them: each listed face's person listed as a body (its
    digits), its ``body_<id>`` frame at its face frame's origin, matched to its face on
    ``candidate_matches`` when it appears (confidence 1) and unmatched when it goes (0); every
    gesture a body's topic carries is the offline command's for that person on that frame, and
    a body is seen WAVING when the offline command reads it. Returns the bodies seen waving."""
    faces = {stamp_ns(m.header): set(m.ids) for m in collector.tracked}
    bodies = {stamp_ns(m.header): set(m.ids) for m in collector.bodies}
    assert set(bodies) == set(faces)
    for stamp, listed in faces.items():
        assert bodies[stamp] == {'b' + face[1:] for face in listed}
        for face in listed:
            optical = collector.transforms[stamp][0].header.frame_id
            ident = int(face[1:])
            at, _ = _lookup(collector.transforms[stamp], optical, frame_name('head', ident))
            body_at, body = _lookup(collector.transforms[stamp], optical, frame_name('body', ident))
            np.testing.assert_allclose(body_at, at, atol=1e-9)
            np.testing.assert_allclose(body.apply([0, 0, 1]), [0, -1, 0], atol=0.2)  # upright: up is the image's up
    seen = sorted({body for listed in bodies.values() for body in listed})
    matched = {(m.id1, m.id1_type, m.id2, m.id2_type, m.confidence) for m in collector.matches}
    for body in seen:
        assert ('f' + body[1:], IdsMatch.FACE, body, IdsMatch.BODY, 1.0) in matched
    last = bodies[max(bodies)]
    for body in set(seen) - last:
        assert ('f' + body[1:], IdsMatch.FACE, body, IdsMatch.BODY, 0.0) in matched
    index_of = {frame.stamp_ns: index for index, frame in enumerate(frames)}
    offline = {(int(r['frame']), int(r['id'])): r['gesture'] for r in rows if r['kind'] == 'head' and r['id']}
    received = 0
    for body, messages in collector.gestures.items():
        for stamp, message in messages.items():
            assert str(Gesture(message.gesture)) == offline[index_of[stamp], int(body[1:])]
            received += 1
    waving = {
        body
        for body, messages in collector.gestures.items()
        for m in messages.values()
        if m.gesture == GestureMessage.WAVING
    }
    waving_rows = sum(g == 'waving' for g in offline.values())
    print(f'bodies: {len(seen)}, {received} gesture messages as offline, waving: {sorted(waving)} ({waving_rows} rows)')
    assert bool(waving) == (waving_rows > 0)
    return waving


def test_a_waving_person_is_a_body_whose_gesture_topic_says_so(tmp_path) -> None:
    """people_crossing, target:=person: the waving person is a ROS4HRI body matched to their
    face, with a ``body_<id>`` frame, and their gesture topic says WAVING on the frames the
    offline command reads it (the walker's head, one person followed, is not taken up)."""
    bag = REPO / 'bags' / 'people_crossing'
    frames = list(read_frames(bag))
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, depth=2 * len(frames)) + ['-p', 'target:=person']
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(
        pipeline, bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames), diagnostics_of='/tracker_node', standard=True
    )
    track_sequence(bag, tmp_path / 'offline', TrackOptions(target='person', video=False, progress=False))
    rows = list(csv.DictReader((tmp_path / 'offline' / 'poses.csv').open()))
    assert _check_bodies(collector, frames, rows)


def _same_point(a: Any, b: Any) -> bool:
    return bool(np.allclose((a.x, a.y, a.z), (b.x, b.y, b.z), atol=1e-9))


def _set(client: AsyncParameterClient, node: Node, name: str, value) -> SetParametersResult:
    future = client.set_parameters([Parameter(name, value=value)])
    rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
    return future.result().results[0]


def _get(client: AsyncParameterClient, node: Node, name: str) -> object:
    future = client.get_parameters([name])
    rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
    return parameter_value_to_python(future.result().values[0])


def test_params_file_loads_and_gains_change_at_run_time(tmp_path) -> None:
    """The shipped YAML with one gain edited, loaded with --params-file; then changed live."""
    params = tmp_path / 'params.yaml'
    shipped = (REPO / 'config' / 'human_tracker.yaml').read_text()
    assert shipped.count('    likelihood_gain: 0.01\n') == 1
    params.write_text(shipped.replace('    likelihood_gain: 0.01\n', '    likelihood_gain: 0.013\n'))
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        ['--ros-args', '--params-file', str(params)],
        environment(),
        tmp_path / 'tracker.log',
    )
    tracker.start()
    rclpy.init()
    node = Node('parameter_test')
    try:
        client = AsyncParameterClient(node, 'tracker_node')
        assert client.wait_for_services(timeout_sec=60.0), tracker.output()
        assert _get(client, node, 'likelihood_gain') == pytest.approx(0.013)
        assert _get(client, node, 'motion_mode') == 'weighted'
        assert _get(client, node, 'min_target_width') == 20.0  # the head's; commented out in the file
        refused = _set(client, node, 'likelihood_gain', -1.0)
        assert not refused.successful and refused.reason
        refused = _set(client, node, 'process_noise', [1.0, 2.0])
        assert not refused.successful and 'process_noise' in refused.reason
        refused = _set(client, node, 'motion_mode', 'telepathy')
        assert not refused.successful and 'motion_mode' in refused.reason
        assert _set(client, node, 'likelihood_gain', 0.02).successful
        assert _get(client, node, 'likelihood_gain') == pytest.approx(0.02)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        assert tracker.stop() == 0
    assert "parameters changed: {'likelihood_gain': 0.02}" in tracker.output()


@pytest.mark.parametrize(
    ('node', 'parameter', 'reason'),
    [
        ('tracker_node', 'image_transport:=carrier_pigeon', "image_transport must be 'raw' or 'compressed'"),
        ('tracker_node', 'num_particles:=-5', 'num_particles'),
        ('tracker_node', 'num_particles:=many', 'num_particles'),
        ('tracker_node', 'search_halfwidth:=0.0', 'search_halfwidth'),
        ('tracker_node', 'target:=elbow', "target must be one of head, hand, person, got 'elbow'"),
        ('tracker_node', 'template_file:=/nonexistent/template.json', 'cannot load template'),
        ('tracker_node', 'motion_mode:=telepathy', 'motion_mode must be one of'),
        ('tracker_node', 'interior_weight:=0.5', 'interior_weight'),
        ('skin_node', 'model_file:=/nonexistent/skin.json', 'cannot load skin model'),
        ('skin_node', 'cell_size:=1', 'cell_size'),
        ('skin_node', 'regions:=blobs', 'regions must be one of'),
    ],
)
def test_nonsense_parameters_at_start_are_refused(tmp_path, node: str, parameter: str, reason: str) -> None:
    process = NodeProcess(f'human_tracker.ros.{node}', ['--ros-args', '-p', parameter], environment(), tmp_path / 'log')
    assert process.start().wait(60.0) == 2, process.output()
    assert reason in process.output()
    assert 'Traceback' not in process.output()


@pytest.mark.parametrize('stop_signal', [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_the_node_between_callbacks(tmp_path, stop_signal: signal.Signals) -> None:
    """Ctrl-C (or SIGTERM from ros2 launch) while a node warms up from an empty kernel cache:
    the warm-up callback ends, then the node stops with exit code 0. A signal that broke into
    the callback, with rclpy shutting the context down from its own thread, made a pipeline
    exit now and then with a segmentation fault."""
    env = {**environment(), 'NUMBA_CACHE_DIR': str(tmp_path / 'numba_cache')}
    process = NodeProcess('human_tracker.ros.skin_node', [], env, tmp_path / 'skin.log').start()
    deadline = time.monotonic() + 60.0
    while 'warming up' not in process.output() and process.process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    process.process.send_signal(stop_signal)
    assert process.wait(120.0) == 0, process.output()
    assert 'warmed up in' in process.output().split('warming up')[-1], process.output()


def test_a_looping_replay_starts_the_tracker_over(tmp_path, head_bag) -> None:
    """bag_play --loop: stamps jump back at each loop; the nodes reset and go on, nothing is skipped."""
    frames = list(read_frames(head_bag))[:20]
    bag = write_bag_for_test(tmp_path, frames)
    env = environment()
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        node_arguments(COMPRESSED_CAMERA_TOPIC, True, frames[0].ground_truth),
        env,
        tmp_path / 'tracker.log',
    )
    player = NodeProcess(
        'human_tracker.ros.bag_play',
        [str(bag), '--loop', '--rate', '2.0', '--wait-for-subscribers', COMPRESSED_CAMERA_TOPIC, '1'],
        env,
        tmp_path / 'bag_play.log',
    )

    def looped_twice(collector: PoseCollector) -> bool:
        diagnostics = collector.diagnostics.get('/tracker_node', {})
        return int(diagnostics.get('time_resets', 0)) >= 2 and int(diagnostics.get('frames_processed', 0)) >= 50

    diagnostics = _run_tracker_with_player(tracker, player, looped_twice).diagnostics.get('/tracker_node', {})
    print(f'tracker_node diagnostics after looping: {diagnostics}')
    assert int(diagnostics['time_resets']) >= 2
    assert int(diagnostics['frames_processed']) >= 50
    assert diagnostics['frames_skipped'] == '0'
    assert diagnostics['state'] == 'TRACKING'


def test_use_sim_time_with_the_bag_clock(tmp_path, head_bag) -> None:
    """bag_play --clock publishes /clock; nodes on use_sim_time track and stamp as usual."""
    frames = list(read_frames(head_bag))[:30]
    short = write_bag_for_test(tmp_path, frames)
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, frames[0].ground_truth) + ['-p', 'use_sim_time:=true']
    env = environment()
    tracker = NodeProcess('human_tracker.ros.tracker_node', args, env, tmp_path / 'tracker.log')
    player = NodeProcess(
        'human_tracker.ros.bag_play',
        [str(short), '--clock', '--wait-for-subscribers', COMPRESSED_CAMERA_TOPIC, '1'],
        env,
        tmp_path / 'play.log',
    )

    def all_tracked(collector: PoseCollector) -> bool:
        processed = collector.diagnostics.get('/tracker_node', {}).get('frames_processed')
        return len(collector.poses) >= len(frames) and processed == str(len(frames))

    collector = _run_tracker_with_player(tracker, player, all_tracked)
    assert sorted(collector.poses) == [f.stamp_ns for f in frames]
    assert collector.diagnostics.get('/tracker_node', {}).get('frames_processed') == str(len(frames))


def test_a_box_on_init_roi_starts_the_tracker_and_reset_forgets_it(tmp_path, head_bag) -> None:
    """Without init_box or a motion cue the tracker waits; a box on init_roi starts it on the
    next frame (a pose on every frame, the contour on the box), and ~/reset makes it WAITING."""
    frames = list(read_frames(head_bag))[:20]
    bag = write_bag_for_test(tmp_path, frames)
    env = environment()
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        node_arguments(COMPRESSED_CAMERA_TOPIC, True),
        env,
        tmp_path / 'tracker.log',
    )
    player = NodeProcess(
        'human_tracker.ros.bag_play',
        # Once the tracker is ready: frames sent while it warmed up reached it in a burst, and
        # the collector, on a loaded machine, missed poses of it (keep-last 10).
        [str(bag), '--rate', '2.0', '--wait-for-ready', '/tracker_node'],
        env,
        tmp_path / 'bag_play.log',
    )
    x, y, w, h = frames[0].ground_truth
    with collecting() as (collector, executor):
        roi = collector.create_publisher(RegionOfInterest, 'init_roi', 10)
        reset = collector.create_client(Trigger, '/tracker_node/reset')

        def spin_until(done: Callable[[], bool], timeout: float) -> bool:
            deadline = time.monotonic() + timeout
            while not done() and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            return done()

        try:
            tracker.start()
            assert spin_until(lambda: roi.get_subscription_count() > 0, 60.0), tracker.output()
            assert spin_until(lambda: collector.states() == ['WAITING'], 30.0), tracker.output()
            roi.publish(RegionOfInterest(x_offset=int(x), y_offset=int(y), width=int(w), height=int(h)))
            player.start()
            assert spin_until(lambda: len(collector.poses) == len(frames), 60.0), tracker.output()
            assert reset.wait_for_service(timeout_sec=10.0)
            answer = reset.call_async(Trigger.Request())
            executor.spin_until_future_complete(answer, timeout_sec=10.0)
            assert answer.result() is not None and answer.result().success
            assert spin_until(lambda: collector.states()[-1] == 'WAITING', 10.0)
        finally:
            player.stop()
            assert tracker.stop() == 0
    assert sorted(collector.poses) == [f.stamp_ns for f in frames]
    assert collector.states() == ['WAITING', 'TRACKING', 'WAITING']
    assert collector.statuses[-1].keys() == {'state'}  # a reset tracker has no estimate to report
    assert 0.3 < float(collector.statuses[-2]['confidence']) <= 1.0
    first = _boxes(collector, frames[:1])[0]
    assert summarise([first], [frames[0].ground_truth])['precision_20px'] == 1.0


def _run_tracker_with_player(
    tracker: NodeProcess, player: NodeProcess, done: Callable[[PoseCollector], bool], timeout: float = 30.0
) -> PoseCollector:
    """Start the tracker, then the player once the tracker publishes; collect until ``done`` or ``timeout`` s."""
    with collecting() as (collector, executor):
        try:
            tracker.start()
            assert collector.wait_for_publisher(executor, 60.0), tracker.output()
            player.start()
            deadline = time.monotonic() + timeout
            while not done(collector) and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
        finally:
            player.stop()
            assert tracker.stop() == 0
    return collector


def write_bag_for_test(tmp_path, frames) -> object:
    from human_tracker.io.bags import write_bag

    return write_bag(
        tmp_path / 'short',
        [(f.stamp_ns, cv2.imdecode(f.message.data, cv2.IMREAD_COLOR), f.ground_truth) for f in frames],
    )


def test_a_lens_with_distortion_is_undistorted_before_the_pose(tmp_path, head_bag) -> None:
    """video_publisher sends camera_info with plumb_bob coefficients from a calibration file; the
    tracker's poses are the rays of undistorted pixels (and would be metres off without)."""
    frames = list(read_frames(head_bag))[:10]
    folder = tmp_path / 'frames'
    folder.mkdir()
    for index, frame in enumerate(frames):
        cv2.imwrite(str(folder / f'{index:04d}.png'), cv2.imdecode(frame.message.data, cv2.IMREAD_COLOR))
    k = [520.0, 0.0, 100.0, 0.0, 515.0, 60.0, 0.0, 0.0, 1.0]  # the head far from the axis: bent most
    distortion = [-0.3, 0.1, 0.001, -0.002, 0.0]
    (tmp_path / 'camera.yaml').write_text(
        'image_width: 640\nimage_height: 480\ncamera_name: test\n'
        f'camera_matrix: {{rows: 3, cols: 3, data: {k}}}\ndistortion_model: plumb_bob\n'
        f'distortion_coefficients: {{rows: 1, cols: 5, data: {distortion}}}\n'
    )
    env = environment()
    box = '[' + ', '.join(f'{v:.2f}' for v in frames[0].ground_truth) + ']'
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        ['--ros-args', '-p', f'init_box:={box}', '-p', 'qos_reliability:=reliable', '-p', 'qos_depth:=100']
        + ['-r', 'image:=image_raw'],
        env,
        tmp_path / 'tracker.log',
    )
    camera = NodeProcess(
        'human_tracker.ros.video_publisher',
        ['--ros-args', '-p', f'source:={folder}', '-p', 'rate:=5.0', '-p', 'wait_for_subscribers:=1']
        + ['-p', f'camera_info_file:={tmp_path / "camera.yaml"}'],
        env,
        tmp_path / 'camera.log',
    )
    done = lambda c: len(c.poses) == len(c.contours) == len(frames)  # noqa: E731
    collector = _run_tracker_with_player(tracker, camera, done, timeout=60.0)
    assert len(collector.poses) == len(frames), tracker.output()
    template, matrix = head_and_shoulders(), np.reshape(k, (3, 3))
    published, undistorted, pinhole = [], [], []
    for stamp, pose in sorted(collector.poses.items()):
        state = fit_template(template, collector.contours[stamp])[0]
        published.append([pose.pose.pose.position.x, pose.pose.pose.position.y, pose.pose.pose.position.z])
        undistorted.append(metric_positions(state, template, matrix, 0.16, distortion))
        pinhole.append(metric_positions(state, template, matrix, 0.16))
    # A frame that reaches the tracker before the first camera_info uses the default camera.
    matches = np.all(np.abs(np.subtract(published, undistorted)) < 2e-3, axis=1)
    first = int(np.argmax(matches))
    assert first <= 2 and matches[first:].all(), (published, undistorted)
    assert np.all(np.linalg.norm(np.subtract(published, pinhole)[first:], axis=1) > 0.01)


def test_the_distance_comes_from_a_registered_depth_image(tmp_path) -> None:
    """An RGB-D bag (generated: the face bulging 10 cm towards the camera, holes, noise growing
    with distance, the wall behind the head): with depth_input the pose's z is the readings' in
    the head plus surface_to_centre, within 5 % of the head centre's true distance (median); the
    scale's distance is shown beside it."""
    spec = dataclasses.replace(SCENES['head_basic'], name='rgbd', num_frames=40, depth=True)
    bag = write_scene_bag(spec, tmp_path / 'rgbd_bag')
    truth = {f.stamp_ns: default_camera_matrix(640, 480)[0, 0] * HEAD_WIDTH / f.state[2] for f in render_scene(spec)}
    frames = list(read_frames(bag))
    errors = {}
    # The pipeline hands its in-process motion mask over with each frame, the depth comes by topic.
    for executable, depth_input in (('tracker_node', True), ('tracker_node', False), ('pipeline', True)):
        args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, frames[0].ground_truth)
        args += ['-p', f'depth_input:={str(depth_input).lower()}', '-r', f'depth:={DEPTH_TOPIC}']
        log = tmp_path / f'{executable}_{depth_input}.log'
        tracker = NodeProcess(f'human_tracker.ros.{executable}', args, environment(), log)
        collector = replay_and_collect(tracker, bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames))
        assert sorted(collector.poses) == sorted(truth), tracker.output()
        relative = [abs(p.pose.pose.position.z / truth[stamp] - 1) for stamp, p in collector.poses.items()]
        errors[executable, depth_input] = error = float(np.median(relative))
        spreads = [np.sqrt(np.reshape(p.pose.covariance, (6, 6))[2, 2]) for p in collector.poses.values()]
        print(
            f'{executable}, depth_input {depth_input}: median relative error {error:.3f}, σ_z {np.median(spreads):.3f}'
        )
    assert errors['tracker_node', True] < 0.05
    assert errors['pipeline', True] < 0.05


def _change_state(node: Node, executor: Any, target: str, transition: int) -> bool:
    """Ask ``target``'s lifecycle interface for ``transition``; whether it succeeded."""
    client = node.create_client(ChangeState, f'{target}/change_state')
    assert client.wait_for_service(timeout_sec=30.0)
    answer = client.call_async(ChangeState.Request(transition=Transition(id=transition)))
    executor.spin_until_future_complete(answer, timeout_sec=10.0)
    node.destroy_client(client)
    return answer.result() is not None and answer.result().success


def test_a_managed_tracker_works_only_while_active(tmp_path, head_bag) -> None:
    """tracker_node with managed:=true waits unconfigured: the frames of a replay are dropped
    unconverted (counted inactive) and nothing is published; configured and activated, it
    tracks the next replay from the start box; deactivated, it drops frames again, and its face
    leaves REP-155's list at once; activated again, the replay's face is listed; stopped, the list
    is empty."""
    frames = list(read_frames(head_bag))[:20]
    bag = write_bag_for_test(tmp_path, frames)
    env = environment()
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, frames[0].ground_truth) + ['-p', 'managed:=true']
    args += ['-p', 'min_particles:=100', '-p', 'kld_bin:=[0.2, 0.2, 0.1, 0.2]']  # KLD-sampling's count reported
    tracker = NodeProcess('human_tracker.ros.tracker_node', args, env, tmp_path / 'tracker.log')

    def replay(name: str) -> None:
        player = NodeProcess(
            'human_tracker.ros.bag_play',
            [str(bag), '--rate', '4.0', '--wait-for-subscribers', COMPRESSED_CAMERA_TOPIC, '1'],
            env,
            tmp_path / f'{name}.log',
        )
        assert player.start().wait(60.0) == 0, player.output()

    def diagnostics(collector: PoseCollector, executor: Any, received: int) -> dict[str, str]:
        """The tracker's diagnostics once they count ``received`` frames (or after 15 s)."""
        deadline = time.monotonic() + 15.0
        values = collector.spin_until_diagnostics(executor, '/tracker_node', 5.0)
        while values.get('frames_received') != str(received) and time.monotonic() < deadline:
            values = collector.spin_until_diagnostics(executor, '/tracker_node', 5.0)
        return values

    def spin(seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)

    with collecting(standard=True) as (collector, executor):
        try:
            tracker.start()
            assert collector.wait_for_publisher(executor, 60.0), tracker.output()
            replay('inactive')
            inactive = diagnostics(collector, executor, len(frames))
            assert not collector.poses
            assert _change_state(collector, executor, '/tracker_node', Transition.TRANSITION_CONFIGURE)
            assert _change_state(collector, executor, '/tracker_node', Transition.TRANSITION_ACTIVATE)
            replay('active')
            deadline = time.monotonic() + 20.0
            while len(collector.poses) < len(frames) and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            active = diagnostics(collector, executor, 2 * len(frames))
            faces_while_active = list(collector.tracked[-1].ids)
            assert _change_state(collector, executor, '/tracker_node', Transition.TRANSITION_DEACTIVATE)
            spin(0.5)
            faces_once_inactive = list(collector.tracked[-1].ids)
            regions_once_inactive = collector.count_publishers('/humans/faces/f00001/roi')
            poses = len(collector.poses)
            replay('deactivated')
            deactivated = diagnostics(collector, executor, 3 * len(frames))
            assert _change_state(collector, executor, '/tracker_node', Transition.TRANSITION_ACTIVATE)
            replay('active again')
            spin(2.0)
            faces_active_again = list(collector.tracked[-1].ids)
        finally:
            assert tracker.stop() == 0
        # The stopped node's last, empty list: late on a busy machine.
        deadline = time.monotonic() + 10.0
        while collector.tracked[-1].ids and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
    print(f'faces: active {faces_while_active}, inactive {faces_once_inactive}, active again {faces_active_again}')
    print(f'after the node stopped: {list(collector.tracked[-1].ids)}')
    # REP-155: the face leaves the list, and its region topic, as soon as nothing is tracked.
    assert faces_while_active == ['f00001'] and faces_once_inactive == [] and regions_once_inactive == 0
    # The replay starts over (time went back): a new track, under a new id.
    assert faces_active_again == ['f00002'] and collector.tracked[-1].ids == []
    print(f'inactive: {inactive}\nactive: {active}\ndeactivated: {deactivated}')
    assert inactive['frames_inactive'] == str(len(frames)) and inactive['frames_processed'] == '0'
    assert inactive['state'] == 'WAITING'
    assert poses == len(frames) and active['frames_processed'] == str(len(frames))
    assert 100 <= int(active['particles']) < 500  # the cloud gathered on the head: fewer than the most
    assert deactivated['frames_inactive'] == str(2 * len(frames))
    assert deactivated['frames_processed'] == str(len(frames)) and len(collector.poses) == poses
