"""``tracker_node``: the particle-filter contour tracker as a ROS 2 node.

Subscribes ``image`` (or ``image/compressed``), ``camera_info`` and, with
``motion_input: foreground`` or ``motion``, that mask topic, and with ``skin_input: true``
the ``skin`` labels, each matched to the image by exact stamp. Publishes ``pose``
(PoseWithCovarianceStamped, metres, optical frame), ``velocity`` (TwistWithCovarianceStamped,
m/s and rad/s, optical frame) and ``contour`` (PolygonStamped, pixels) while the target is
tracked, ``status`` (DiagnosticArray, latched: WAITING / TRACKING /
LOST with the confidence and each cue's support, on every change and every
``status_period``), ``markers`` (MarkerArray for RViz: the contour at the target's depth and
a label, while the filter has an estimate) and ``debug_image`` (each only when subscribed),
and ``/diagnostics``. Every output copies the header of the image it was computed from.

A box on ``init_roi`` (sensor_msgs/RegionOfInterest, image pixels) starts the filter there on
the next frame; the service ``~/reset`` (std_srvs/Trigger) forgets the target: WAITING for
motion or a box.

With ``target: person`` it follows a head and ``hands`` hands of up to ``max_people`` people
(:mod:`~human_tracker.vision.people.persons`): the topics above are the primary target's, on each
frame the head ``primary_id`` names while it is followed, else the followed head nearest the
image's centre (:func:`~human_tracker.vision.track.outcomes.primary_target`), and
``targets`` (nav_msgs/Odometry, one message per tracked target per frame) gives every target:
``child_frame_id`` ``person_<person>/<kind>_<id>``, the pose and its covariance in the image's
optical frame (``header``); the twist is not estimated per target (unknown covariance).

Every TRACKING target is also on what a robot's other software reads
(:mod:`~human_tracker.ros.standard_outputs`): a TF frame on ``/tf``, ROS4HRI's
``/humans/faces/tracked`` and ``/humans/faces/<id>/roi`` for heads, and vision_msgs'
``detections`` and ``detections_3d``.
"""

from __future__ import annotations

import contextlib
import sys
import time
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np
from rclpy.lifecycle import LifecycleState, TransitionCallbackReturn
from sensor_msgs.msg import RegionOfInterest
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from human_tracker.ros.common import RESULT_QOS
from human_tracker.ros.run import spin_node
from human_tracker.ros.stage import DEFERRED, ImageStage, stamp_ns
from human_tracker.ros.stamp_matching import FrameGaps, HeldFrame, MaskInputs
from human_tracker.ros.status_topic import PrimaryState, StatusTopic
from human_tracker.ros.tracker_outputs import PublishedFrame, TrackerOutputs, estimate_values
from human_tracker.ros.tracker_parameters import SURFACE_TO_CENTRE, TARGET_WIDTHS, declare_settings, start_problem
from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.cues.resolution import same_frame
from human_tracker.vision.cues.skin import has_colour
from human_tracker.vision.filter.contour_filter import TrackerParameters, check_box_in_image
from human_tracker.vision.frame_pipeline import FramePipeline, build_people
from human_tracker.vision.people.persons import TrackedTarget, targets_line
from human_tracker.vision.track.target import TargetParameters, TargetResult, parameters_for

__all__ = ['TrackerNode', 'main']

# Seconds a stopping node waits for its consumers to acknowledge its last, empty list of faces.
LAST_WORD_WAIT = 2.0
GREY_INPUT_TEXT = 'the image has no colour (a grey-level camera?): no skin can be found, so no hand is followed'


class TrackerNode(ImageStage):
    """Tracks a head (or hand) silhouette in the image stream and publishes its pose."""

    def __init__(self, *, subscribe_image: bool = True, **kwargs: Any) -> None:
        super().__init__('tracker_node', subscribe_image=subscribe_image, **kwargs)
        settings = self.settings = declare_settings(self)
        # The primary target (the head of a person) is the one of pose, contour, status and markers.
        self.kinds = settings.kinds
        self.kind = self.kinds[0]
        filter_parameters = self.bind_parameters(TrackerParameters(), self._apply_filter)
        # Each kind's cue and loss constants: a person's hands under ``hand.`` (``hand.lost_frames``).
        target_parameters = {
            kind: self.bind_parameters(
                parameters_for(kind),
                partial(self._apply_target, kind),
                prefix='' if kind == self.kind else f'{kind}.',
            )
            for kind in dict.fromkeys(self.kinds)
        }
        self.init_box = settings.init_box
        self.gaps = FrameGaps()
        self.last_result: TargetResult | None = None
        self.last_outcomes: list[TrackedTarget] = []
        self.outputs = TrackerOutputs(self, settings)
        self.status_topic = StatusTopic(self, self._primary_state)
        self.create_timer(settings.status_period, self.status_topic.publish, clock=self.steady_clock)
        self.requested_box: tuple[float, float, float, float] | None = None
        self.create_subscription(RegionOfInterest, 'init_roi', self._on_init_roi, RESULT_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.use_camera_info()
        # The mask topics each frame waits for; a pipeline hands the masks over with the frames,
        # but not the depth image.
        motion = settings.motion_input
        topics = ([motion] if motion != 'none' else []) + (['skin'] if settings.skin_input else [])
        self.mask_topics = (topics if subscribe_image else []) + (['depth'] if settings.depth_input else [])
        self.inputs = MaskInputs(self, self.mask_topics, settings.max_pending, self._track_held)
        self.frames_motion_set_aside = 0
        self.frames_without_colour = 0
        self.last_frame_grey = False
        self.start_problem: str | None = None
        if self.describing:
            return
        self.frame_pipeline = FramePipeline(
            build_people(
                settings.target,
                filter_parameters,
                target_parameters,
                hands=settings.hands,
                max_people=settings.max_people,
                id_hold_frames=settings.id_hold_frames,
                template_file=settings.template_file,
                num_points=settings.num_points,
            )
        )
        self.people = self.frame_pipeline.people
        self.tracker = self.people.first(self.kind)
        self.template = self.tracker.template
        self.primary = self.tracker  # the tracker of this frame's primary target
        if self.tracker.proposals_problem is not None:
            self.get_logger().warn(self.tracker.proposals_problem)
        if subscribe_image:
            self.check_start(motion=motion != 'none', skin=settings.skin_input)
        self.status_topic.publish()
        # In a pipeline the cues come with the frames, measured in process; only a depth topic is read.
        inputs = f'mask inputs: {", ".join(self.mask_topics) or "none"}'
        if not subscribe_image:
            inputs = 'cues measured in process' + (', depth topic' if settings.depth_input else '')
        self.get_logger().info(
            f'configured: tracking {settings.target} with {filter_parameters.num_particles} particles, '
            f'{self.template.num_points} points, {inputs}'
        )

    def _setting(self, name: str) -> Any:
        """A setting that may change at run time, as it is now."""
        return self.get_parameter(name).value

    @property
    def uses_skin(self) -> bool:
        """Whether a target's tracker wants skin labels (a hand's)."""
        return 'hand' in self.kinds

    def check_start(self, *, motion: bool, skin: bool) -> None:
        """Say (log, diagnostics) when these inputs can never start the tracker by itself.

        Without ``init_box`` the filter starts from the region of ``init_region``: the motion
        mask or the skin labels. A node given neither waits for ever; it is told at start.
        """
        if self.init_box is None and not self.describing:
            self.start_problem = start_problem(self.tracker.parameters.init_region, motion=motion, skin=skin)
            if self.start_problem is not None:
                self.get_logger().warn(self.start_problem)

    def warm_up(self) -> None:
        """Run the compiled kernels once, with this node's settings, so the first real frame is not late."""
        self.frame_pipeline.warm_up()

    def unconnected_inputs(self) -> list[str]:
        """The mask topics no publisher is matched on yet: their first masks would be lost."""
        return self.inputs.unconnected()

    def on_image(self, msg: Any) -> None:
        """Remember the stamp of every frame that reached this node, usable or not, then process it."""
        self.inputs.matcher.arrived(stamp_ns(msg.header))
        super().on_image(msg)

    def _apply_filter(self, parameters: TrackerParameters) -> None:
        """A run-time change of the filters' constants, to every target's filter (each keeps its seed)."""
        for tracker in self.people.trackers:
            tracker.set_filter_parameters(replace(parameters, seed=tracker.filter_parameters.seed))

    def _apply_target(self, kind: str, parameters: TargetParameters) -> None:
        """A run-time change of ``kind``'s cue and loss constants, to every target of that kind."""
        for slot in self.people.slots:
            if slot.kind == kind:
                slot.tracker.parameters = parameters

    def reset_state(self) -> None:
        """Time went backwards: start over (the initial box applies again, held frames are dropped)."""
        self.people.reset()
        self.counters.skipped += self.inputs.matcher.clear()
        self.gaps.last_stamp = -1
        self.outputs.last_distance = None

    def _track_held(self, frame: HeldFrame, masks: dict[str, np.ndarray | None]) -> None:
        """Track a frame that waited for its masks (a topic's None: it never came)."""
        cues = {'motion': masks[self.settings.motion_input]} if self.settings.motion_input in masks else {}
        if 'skin' in masks:
            cues['skin'] = masks['skin']
        start = time.perf_counter()
        self.guarded(self.track, frame.header, frame.evidence.with_cues(**cues), masks.get('depth'))
        self.timer_stats.took(time.perf_counter() - start)

    def handle_frame(self, image: np.ndarray, header: Any, evidence: Evidence | None = None) -> object:
        """Track on one frame: now when no mask is expected, else once they arrive. ``evidence``:
        the frame's cues as ``pipeline`` measured them in process; None: the frame alone."""
        stamp = stamp_ns(header)
        evidence = evidence or Evidence(image, stamp_ns=stamp)
        if not self.mask_topics:
            return self.track(header, evidence)
        if not self.inputs.matcher.held and not self.inputs.matcher.has_masks(stamp):
            # The frame's own work (reduction, colour bins, edges: 1 of the tracker's 4 ms at
            # 640x480) is done while another node makes its masks, not after they arrive; not
            # while an earlier frame waits, whose masks may come meanwhile and would wait.
            with contextlib.suppress(Exception):  # tracking the frame meets the same error and reports it
                self.people.prepare(evidence)
        self.inputs.hold(HeldFrame(stamp, time.monotonic(), header, evidence))
        return DEFERRED

    def track(self, header: Any, evidence: Evidence, depth: np.ndarray | None = None) -> TargetResult:
        """Step 2 of the frame path (:meth:`FramePipeline.track`) on the frame's ``evidence``, its
        masks checked against the frame; publish what it found under ``header`` and return the
        primary target's result."""
        image = evidence.image
        stamp = stamp_ns(header)
        interval, gap = self.gaps.next(stamp, self._setting('max_gap'))
        if gap is not None:
            # After a gap the dynamics predict nothing: let motion restart the filter.
            for tracker in self.people.trackers:
                tracker.mark_lost()
            self.get_logger().warn(f'{gap}: target marked lost', throttle_duration_sec=5.0)
        if self.uses_skin:
            self._check_colour(image)
        size = image.shape[:2]
        motion = self._of_frame(evidence.motion, size, 'mask', 'mask_size')
        skin = self._of_frame(evidence.skin, size, 'skin labels', 'skin_size')
        depth = self._of_frame(depth, size, 'depth image', 'depth_size')
        self._start_on_boxes(size)
        found = self.frame_pipeline.track(
            evidence.with_cues(motion=motion, skin=skin, stamp_ns=stamp), self._setting('primary_id')
        )
        primary = found.primary
        self.primary = self.people.slot(primary.name).tracker
        self.last_result, self.last_outcomes = primary.result, found.outcomes
        self.status_topic.on_frame(header)
        if found.motion_set_aside:
            self.frames_motion_set_aside += 1
            self.get_logger().warn(
                'the motion mask covers most of the frame (camera moving, or light changed?): tracking on edges alone',
                throttle_duration_sec=5.0,
            )
        self.counters.processed += 1
        self.outputs.publish(
            PublishedFrame(
                image,
                header,
                found.outcomes,
                primary,
                {outcome.name: self.people.slot(outcome.name).tracker for outcome in found.outcomes},
                self.camera.lens(size[1], size[0], self.settings.image_rectified),
                self._sizes(),
                interval,
                depth,
                motion if motion is not None else skin,
                found.gestures,
            )
        )
        return primary.result

    def _sizes(self) -> dict[str, tuple[float, float]]:
        """Each kind's width and surface-to-centre depth, metres: the primary kind's from its
        parameters (they change at run time), the others' typical."""
        sizes = {kind: (TARGET_WIDTHS[kind], SURFACE_TO_CENTRE[kind]) for kind in self.kinds}
        sizes[self.kind] = (self._setting('target_width'), self._setting('surface_to_centre'))
        return sizes

    def _primary_state(self) -> PrimaryState:
        """What ``status`` says now (:class:`~human_tracker.ros.status_topic.PrimaryState`)."""
        return PrimaryState(self.primary.status, self.last_result, self.warnings(), self.last_frame_grey)

    def _start_on_boxes(self, size: tuple[int, ...]) -> None:
        """Start the primary target on a box asked for on ``init_roi``, or on ``init_box`` while
        it has never been started."""
        if self.requested_box is not None:
            box, self.requested_box = self.requested_box, None
            try:
                check_box_in_image(box, size)
                self.tracker.initialise_from_box(box)
                self.get_logger().info(f'started from the box on init_roi {box}')
            except ValueError as err:
                self.counters.reject('init_roi')
                self.get_logger().error(f'init_roi ignored: {err}')
        if self.init_box is not None and not self.tracker.filter.initialised:
            try:
                check_box_in_image(self.init_box, size)
                self.tracker.initialise_from_box(self.init_box)
            except ValueError as err:
                self.init_box = None
                self.start_problem = f'init_box ignored: {err}'
                self.get_logger().error(self.start_problem)

    def _check_colour(self, image: np.ndarray) -> None:
        """Count a frame without colour (a hand's skin cannot be found in it); say so at the first."""
        grey = not has_colour(image)
        if grey and self.frames_without_colour == 0:
            self.get_logger().warn(GREY_INPUT_TEXT)
        self.frames_without_colour += int(grey)
        self.last_frame_grey = grey

    def warnings(self) -> list[str]:
        """The base's, a face detector the targets cannot have (dlib missing: a tracker other
        than the one configured), and a frame without colour for a hand."""
        found = super().warnings()
        found += sorted({t.proposals_problem for t in self.people.trackers if t.proposals_problem is not None})
        if self.last_frame_grey:
            found.append(f'GREY_INPUT: {GREY_INPUT_TEXT}')
        return found

    def _of_frame(self, mask: np.ndarray | None, size: tuple[int, ...], what: str, reason: str) -> np.ndarray | None:
        """``mask`` if it can be the frame of ``size`` at some resolution, else None (rejected as ``reason``).

        Cue stages publish at their own working width, so any resolution of the frame will do.
        """
        if mask is None or same_frame(mask.shape, size):
            return mask
        self.counters.reject(reason)
        self.get_logger().warn(
            f'{what} {mask.shape} cannot be image {size} at any resolution: tracking without it',
            throttle_duration_sec=5.0,
        )
        return None

    def _on_init_roi(self, msg: RegionOfInterest) -> None:
        """Start from this box (x, y, w, h, the image's pixels) on the next frame."""
        if msg.width == 0 or msg.height == 0:
            self.counters.reject('init_roi')
            self.get_logger().error(f'init_roi ignored: an empty box ({msg.width} x {msg.height})')
            return
        self.requested_box = (float(msg.x_offset), float(msg.y_offset), float(msg.width), float(msg.height))

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Forget the target; the start box does not apply again (it was the first frame's)."""
        self.people.reset()
        self.init_box = self.requested_box = None
        self.last_result, self.last_outcomes = None, []
        self.status_topic.publish()
        response.success = True
        response.message = 'WAITING for motion, or a box on init_roi'
        return response

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.say_nothing_tracked()
        return super().on_deactivate(state)

    def destroy_node(self) -> None:
        if not self.describing:
            with contextlib.suppress(Exception):  # the context may already be shut down: nothing can be said
                self.say_nothing_tracked(settle=LAST_WORD_WAIT)
        super().destroy_node()

    def say_nothing_tracked(self, settle: float = 0.0) -> None:
        """No frame will be tracked for a while (deactivated, shutting down): an empty list of
        faces, now, for the consumers of the standard outputs (``settle``: seconds to wait for
        their acknowledgement, when the publisher is about to go)."""
        self.outputs.standard.clear(Header(stamp=self.get_clock().now().to_msg()), settle)

    def diagnostics_state(self) -> tuple[str, dict[str, Any]]:
        extra: dict[str, Any] = {
            # Each target's particle count now (KLD-sampling moves it between the bounds).
            'particles': ', '.join(
                str(t.filter.particles.shape[0] if t.filter.initialised else t.filter.parameters.num_particles)
                for t in self.people.trackers
            ),
            **{f'frames_without_{topic}': count for topic, count in self.inputs.matcher.unmatched.items()},
            'frames_never_received': self.inputs.matcher.never_received,
            'frames_motion_set_aside': self.frames_motion_set_aside,
            'frames_pending': len(self.inputs.matcher.held),
            'frames_without_depth_reading': self.outputs.frames_without_depth_reading,
            'frames_without_colour': self.frames_without_colour,
            'stalls': self.gaps.stalls,
        }
        if self.start_problem is not None:
            extra['cannot_start'] = self.start_problem
        if len(self.people.kinds) > 1:
            extra['targets'] = targets_line(self.last_outcomes)
        return self.primary.status, {**extra, **estimate_values(self.last_result)}


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker tracker_node``; returns the exit code."""
    return spin_node(TrackerNode, args, name='tracker_node', summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
