"""Paths a user takes that the other tests leave out, over real DDS: a rotating camera's
angular velocity, two hands, a grey camera on ``status``, ``primary_id`` changed at run time,
the ``~/reset`` services, ``debug_image`` drawn only for a subscriber."""

from __future__ import annotations

import csv
import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import rclpy
from conftest import BAGS
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseWithCovarianceStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import QoSProfile, ReliabilityPolicy
from ros_harness import environment, replay_and_collect
from sensor_msgs.msg import CameraInfo, Image
from std_srvs.srv import Trigger
from test_optical_flow import _textured
from test_ros_nodes import _pixel

import human_tracker.ros.tracker_outputs as outputs_module
from human_tracker.demo import node_arguments
from human_tracker.io.bags import COMPRESSED_CAMERA_TOPIC, read_frames
from human_tracker.offline import TrackOptions, track_sequence
from human_tracker.ros.background_node import BackgroundNode
from human_tracker.ros.common import LATCHED_QOS
from human_tracker.ros.image_conversion import array_to_image, image_to_array, message_to_bgr8
from human_tracker.ros.optical_flow_node import OpticalFlowNode
from human_tracker.ros.processes import NodeProcess
from human_tracker.ros.skin_node import SkinNode
from human_tracker.ros.tracker_node import TrackerNode
from human_tracker.vision.geometry.boxes import box_centre
from human_tracker.vision.geometry.camera import default_camera_matrix

RELIABLE = QoSProfile(depth=200, reliability=ReliabilityPolicy.RELIABLE)


class Graph:
    """Nodes of this process on one executor; a ``camera`` node for the test's own topics."""

    def __init__(self, *nodes: Node) -> None:
        self.camera = Node('camera')
        self.nodes = [*nodes, self.camera]
        self.executor = SingleThreadedExecutor()
        for node in self.nodes:
            self.executor.add_node(node)

    def spin_until(self, done: Callable[[], bool], timeout: float = 20.0) -> bool:
        deadline = time.monotonic() + timeout
        while not done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return done()

    def spin(self, seconds: float) -> None:
        self.spin_until(lambda: False, seconds)

    def close(self) -> None:
        self.executor.shutdown()
        for node in self.nodes:
            node.destroy_node()


def _header(message: Any, seconds: float, frame_id: str = 'camera_optical_frame') -> Any:
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(int(round(seconds * 1e9)), 10**9)
    message.header.frame_id = frame_id
    return message.header


def test_the_flow_node_takes_the_camera_rotation_it_is_sent() -> None:
    """A pan of a static scene: moving everywhere until the node is sent the camera's angular
    velocity (with camera_info's K), then still (the core's compensation, through the node)."""
    k = np.array([[500.0, 0.0, 160.0], [0.0, 500.0, 120.0], [0.0, 0.0, 1.0]])
    omega, dt = np.array([0.0, 0.3, 0.0]), 1 / 30
    rotation, _ = cv2.Rodrigues(omega * dt)
    first = _textured()
    second = cv2.warpPerspective(
        first, k @ rotation.T @ np.linalg.inv(k), (320, 240), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT
    )
    rclpy.init()
    overrides = [Parameter('qos_reliability', value='reliable'), Parameter('qos_depth', value=10)]
    node = OpticalFlowNode(parameter_overrides=overrides)
    graph = Graph(node)
    try:
        images = graph.camera.create_publisher(Image, 'image', RELIABLE)
        info = graph.camera.create_publisher(CameraInfo, 'camera_info', RELIABLE)
        rates = graph.camera.create_publisher(Vector3Stamped, 'angular_velocity', RELIABLE)
        masks: dict[float, np.ndarray] = {}
        graph.camera.create_subscription(
            Image,
            'motion',
            lambda m: masks.__setitem__(m.header.stamp.sec + m.header.stamp.nanosec / 1e9, image_to_array(m)),
            RELIABLE,
        )
        assert graph.spin_until(lambda: images.get_subscription_count() and rates.get_subscription_count())
        camera_info = CameraInfo(width=320, height=240, distortion_model='plumb_bob', k=k.reshape(-1).tolist())
        camera_info.p = np.hstack([k, np.zeros((3, 1))]).reshape(-1).tolist()
        info.publish(camera_info)
        graph.spin(0.2)
        # Without the angular velocity, then (time going back starts the flow afresh) with it.
        for start, rate in ((10.0, None), (5.0, omega)):
            if rate is not None:
                velocity = Vector3Stamped()
                _header(velocity, start + dt)
                velocity.vector.x, velocity.vector.y, velocity.vector.z = (float(v) for v in rate)
                rates.publish(velocity)
                graph.spin(0.2)
            for offset, image in ((0.0, first), (dt, second)):
                message = array_to_image(image, 'mono8')
                _header(message, start + offset)
                images.publish(message)
            assert graph.spin_until(lambda s=start: round(s + dt, 6) in {round(t, 6) for t in masks})
        compensated_diagnostics = node.diagnostics_state()[1]['rotation_compensation']
    finally:
        graph.close()
        rclpy.try_shutdown()
    moving = {round(t, 3): np.mean(mask[30:-30, 30:-30] > 0) for t, mask in masks.items()}
    print(f'moving fraction by stamp: {moving}')
    assert moving[round(10.0 + dt, 3)] > 0.9 and moving[round(5.0 + dt, 3)] < 0.05
    assert compensated_diagnostics is True


def test_a_hand_on_a_grey_camera_warns_on_status_and_is_never_tracked() -> None:
    frames = [message_to_bgr8(f.message) for f in list(read_frames(BAGS / 'hand_wave'))[:30]]
    rclpy.init()
    node = TrackerNode(
        parameter_overrides=[
            Parameter('target', value='hand'),
            Parameter('qos_reliability', value='reliable'),
            Parameter('qos_depth', value=100),
        ]
    )
    graph = Graph(node)
    statuses: list[DiagnosticStatus] = []
    poses: list[PoseWithCovarianceStamped] = []
    try:
        graph.camera.create_subscription(DiagnosticArray, 'status', lambda m: statuses.extend(m.status), LATCHED_QOS)
        graph.camera.create_subscription(PoseWithCovarianceStamped, 'pose', poses.append, RELIABLE)
        images = graph.camera.create_publisher(Image, 'image', RELIABLE)
        assert graph.spin_until(lambda: images.get_subscription_count() > 0 and statuses)
        for index, image in enumerate(frames):
            message = array_to_image(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), 'mono8')
            _header(message, index / 30)
            images.publish(message)
        assert graph.spin_until(lambda: node.counters.processed == len(frames))
        graph.spin(0.3)
        grey_status = statuses[-1]
        diagnostics = node.diagnostics_state()[1]
        message = array_to_image(frames[0], 'bgr8')  # colour again: the warning goes
        _header(message, 10.0)
        images.publish(message)
        assert graph.spin_until(lambda: node.counters.processed == len(frames) + 1)
        graph.spin(0.3)
        colour_status = statuses[-1]
    finally:
        graph.close()
        rclpy.try_shutdown()
    values = {v.key: v.value for v in grey_status.values}
    assert grey_status.level == DiagnosticStatus.WARN and 'GREY_INPUT' in values['warnings'], values
    assert grey_status.message == 'WAITING' and not poses
    assert diagnostics['frames_without_colour'] == len(frames)
    assert colour_status.level == DiagnosticStatus.OK and 'warnings' not in {v.key for v in colour_status.values}


def test_primary_id_set_at_run_time_moves_pose_to_that_head() -> None:
    """people_crossing, two people: once both heads are followed, a parameter client (as
    ``ros2 param set``) names the head that is not the primary; ``pose`` then follows it."""
    frames = list(read_frames(BAGS / 'people_crossing'))
    overrides = [Parameter('target', value='person'), Parameter('max_people', value=2)]
    rclpy.init()
    node = TrackerNode(subscribe_image=False, parameter_overrides=overrides)
    graph = Graph(node)
    poses: dict[int, PoseWithCovarianceStamped] = {}
    targets: dict[int, dict[str, Odometry]] = {}

    def stamp(header: Any) -> int:
        return header.stamp.sec * 10**9 + header.stamp.nanosec

    try:
        graph.camera.create_subscription(
            PoseWithCovarianceStamped, 'pose', lambda m: poses.__setitem__(stamp(m.header), m), RELIABLE
        )
        graph.camera.create_subscription(
            Odometry,
            'targets',
            lambda m: targets.setdefault(stamp(m.header), {}).__setitem__(m.child_frame_id, m),
            RELIABLE,
        )
        client = AsyncParameterClient(graph.camera, 'tracker_node')
        assert client.wait_for_services(20.0)
        named = None
        switched_at = None
        for index, frame in enumerate(frames):
            image = message_to_bgr8(frame.message)
            node.process_frame(image, frame.message.header)
            graph.spin(0.01)
            heads = [o for o in node.last_outcomes if o.kind == 'head' and o.result.tracking]
            if named is None and len(heads) == 2:
                primary = next(o for o in heads if node.people.slot(o.name).tracker is node.primary)
                named = next(o for o in heads if o is not primary)
                future = client.set_parameters([Parameter('primary_id', value=named.id)])
                assert graph.spin_until(future.done, 10.0) and future.result().results[0].successful
                switched_at = index + 1
        graph.spin(0.5)
    finally:
        graph.close()
        rclpy.try_shutdown()
    assert named is not None, 'the two heads were never followed together'
    name = f'person_{named.person}/head_{named.id}'
    followed = 0
    for frame in frames[switched_at:]:
        on_frame = targets.get(frame.stamp_ns, {})
        if name in on_frame:
            followed += 1
            expected, got = on_frame[name].pose.pose.position, poses[frame.stamp_ns].pose.pose.position
            assert (got.x, got.y, got.z) == (expected.x, expected.y, expected.z)
    print(f'pose followed head {named.id} on {followed} frames after primary_id was set')
    assert followed >= 10


def test_run_time_parameters_reach_every_target_of_a_person() -> None:
    """target:=person, two people with two hands each: a parameter client (as ``ros2 param set``)
    changes the heads' ``lost_frames``, the hands' ``hand.lost_frames`` and a filter constant;
    all six trackers get the change of their kind, and each filter keeps its own seed."""
    overrides = [
        Parameter('target', value='person'),
        Parameter('hands', value=2),
        Parameter('max_people', value=2),
        Parameter('hand.detect_every', value=7),  # the hands' own values, at start too
    ]
    rclpy.init()
    node = TrackerNode(subscribe_image=False, parameter_overrides=overrides)
    graph = Graph(node)
    try:
        slots = node.people.slots
        assert [s.kind for s in slots] == ['head', 'hand', 'hand'] * 2
        seeds = [s.tracker.filter_parameters.seed for s in slots]
        assert len(set(seeds)) == len(slots)
        assert {s.tracker.parameters.detect_every for s in slots if s.kind == 'hand'} == {7}
        assert {s.tracker.parameters.detect_every for s in slots if s.kind == 'head'} == {1}
        client = AsyncParameterClient(graph.camera, 'tracker_node')
        assert client.wait_for_services(20.0)
        changes = [
            Parameter('lost_frames', value=9),
            Parameter('hand.lost_frames', value=11),
            Parameter('likelihood_gain', value=0.02),
        ]
        future = client.set_parameters(changes)
        # Served once the warm-up (every tracker's kernels, in a callback) is over.
        assert graph.spin_until(future.done, 120.0)
        assert all(result.successful for result in future.result().results)
        refused = client.set_parameters([Parameter('hand.lost_frames', value=0)])
        assert graph.spin_until(refused.done, 10.0)
        assert not refused.result().results[0].successful
    finally:
        graph.close()
        rclpy.try_shutdown()
    assert [s.tracker.parameters.lost_frames for s in slots] == [9, 11, 11] * 2
    assert [s.tracker.filter.parameters.likelihood_gain for s in slots] == [
        pytest.approx(0.02 / s.tracker.scale**2) for s in slots
    ]
    assert [s.tracker.filter_parameters.seed for s in slots] == seeds


def test_the_background_and_skin_nodes_forget_on_reset() -> None:
    frames = [message_to_bgr8(f.message) for f in list(read_frames(BAGS / 'hand_wave'))[:12]]
    rclpy.init()
    depth = [Parameter('qos_reliability', value='reliable'), Parameter('qos_depth', value=20)]
    background = BackgroundNode(parameter_overrides=depth)
    skin = SkinNode(parameter_overrides=depth)
    graph = Graph(background, skin)
    foreground: dict[int, np.ndarray] = {}
    try:
        graph.camera.create_subscription(
            Image, 'foreground', lambda m: foreground.__setitem__(m.header.stamp.sec, image_to_array(m)), RELIABLE
        )
        images = graph.camera.create_publisher(Image, 'image', RELIABLE)
        resets = {
            name: graph.camera.create_client(Trigger, f'/{name}/reset') for name in ('background_node', 'skin_node')
        }
        assert graph.spin_until(lambda: images.get_subscription_count() == 2)
        # A learnt background, then a frame with the hand elsewhere: foreground.
        for index in (0, 1, 2, 3, 4, 11):
            message = array_to_image(frames[index], 'bgr8')
            _header(message, index)
            images.publish(message)
        assert graph.spin_until(lambda: 11 in foreground)
        prior = skin.segmenter.prior
        skin.segmenter.model = dataclasses.replace(prior, classes=prior.classes[:1])  # as adapting moves them
        answers = {}
        for name, client in resets.items():
            assert client.wait_for_service(10.0)
            future = client.call_async(Trigger.Request())
            assert graph.spin_until(future.done)
            answers[name] = future.result()
        # After the reset the next frame is the reference: no foreground on it.
        message = array_to_image(frames[11], 'bgr8')
        _header(message, 20)
        images.publish(message)
        assert graph.spin_until(lambda: 20 in foreground)
        model_after = skin.segmenter.model
    finally:
        graph.close()
        rclpy.try_shutdown()
    assert all(answer.success for answer in answers.values()), answers
    assert np.count_nonzero(foreground[11]) > 100 and np.count_nonzero(foreground[20]) == 0
    assert model_after is prior and len(prior.classes) > 1


def test_debug_image_is_drawn_only_while_someone_subscribes(monkeypatch) -> None:
    drawn: list[int] = []
    annotate = outputs_module.annotate

    def counting(*args: Any, **kwargs: Any) -> np.ndarray:
        drawn.append(1)
        return annotate(*args, **kwargs)

    monkeypatch.setattr(outputs_module, 'annotate', counting)
    frames = [message_to_bgr8(f.message) for f in list(read_frames(BAGS / 'head_basic'))[:10]]
    rclpy.init()
    node = TrackerNode(subscribe_image=False)
    graph = Graph(node)
    received: list[Image] = []
    try:
        for index in range(5):
            node.process_frame(frames[index], _header(array_to_image(frames[index], 'bgr8'), index / 30))
        not_subscribed = len(drawn)
        graph.camera.create_subscription(Image, 'debug_image', received.append, RELIABLE)
        assert graph.spin_until(lambda: node.outputs.debug_pub.get_subscription_count() > 0)
        for index in range(5, 10):
            node.process_frame(frames[index], _header(array_to_image(frames[index], 'bgr8'), index / 30))
        assert graph.spin_until(lambda: len(received) == 5)
    finally:
        graph.close()
        rclpy.try_shutdown()
    assert not_subscribed == 0 and len(drawn) == 5
    assert [m.header.stamp.nanosec for m in received] == [round(i / 30 * 1e9) for i in range(5, 10)]


def test_a_person_with_two_hands_over_dds_is_the_offline_command(tmp_path: Path) -> None:
    """``target:=person hands:=2`` in the pipeline on the waving-hand bag: every target on
    ``targets`` (head, both hand slots) at the offline command's positions, under its ids."""
    bag = BAGS / 'hand_wave'
    frames = list(read_frames(bag))
    args = node_arguments(COMPRESSED_CAMERA_TOPIC, True, depth=2 * len(frames))
    args += ['-p', 'target:=person', '-p', 'hands:=2']
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(
        pipeline, bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames), rate=0.5, diagnostics_of='/tracker_node'
    )
    assert collector.diagnostics['/tracker_node']['frames_processed'] == str(len(frames))
    track_sequence(bag, tmp_path / 'offline', TrackOptions(target='person', hands=2, video=False, progress=False))
    offline: dict[tuple[int, str], tuple[float, float]] = {}
    with (tmp_path / 'offline' / 'poses.csv').open() as handle:
        for row in csv.DictReader(handle):
            if row['status'] == 'TRACKING':
                offline[int(row['frame']), f'person_{row["person"]}/{row["kind"]}_{row["id"]}'] = (
                    float(row['x']),
                    float(row['y']),
                )
    height, width = message_to_bgr8(frames[0].message).shape[:2]
    k = default_camera_matrix(width, height)
    over_dds = {
        (frame.index, odometry.child_frame_id)
        for frame in frames
        for odometry in collector.targets.get(frame.stamp_ns, [])
    }
    kinds = {name.split('/')[1].split('_')[0] for _, name in over_dds}
    assert over_dds == set(offline) and kinds == {'head', 'hand'}
    hand_near = hand_in_view = 0
    for frame in frames:
        truth = frame.ground_truth
        hand_in_view += truth is not None
        centres = [
            _pixel(o.pose.pose.position, k)
            for o in collector.targets.get(frame.stamp_ns, [])
            if '/hand_' in o.child_frame_id
        ]
        hand_near += truth is not None and any(np.hypot(*np.subtract(c, box_centre(truth))) <= 20.0 for c in centres)
    print(f'two hand slots over DDS: a hand within 20 px of the waving hand on {hand_near} of {hand_in_view} frames')
    assert hand_near >= 0.9 * hand_in_view
