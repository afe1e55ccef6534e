"""The tracker node's parameters: the filter's and each target kind's constants (bound to the
vision dataclasses, most of them changeable at run time), and the node's own settings.

The node's settings that change at run time (``primary_id``, ``target_width``,
``surface_to_centre``, ``match_timeout``, ``max_gap``) are read where they are used, so a change
takes effect on the next frame; the others are fixed at start (read-only).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from human_tracker.ros.common import declare
from human_tracker.vision.geometry.camera import FIT_RESIDUAL_GAIN
from human_tracker.vision.people.persons import kinds_of

__all__ = [
    'MOTION_INPUTS',
    'SURFACE_TO_CENTRE',
    'TARGET_WIDTHS',
    'TrackerSettings',
    'declare_settings',
]

MOTION_INPUTS = ('none', 'foreground', 'motion')
# Typical adult widths of the reference regions, metres: head (ear to ear) and open hand.
TARGET_WIDTHS = {'head': 0.16, 'hand': 0.18}
# How far behind its visible surface the target's centre lies, metres: a head is about 0.2 m
# deep and the middle of the face about 8 cm in front of its centre; a hand is flat.
SURFACE_TO_CENTRE = {'head': 0.08, 'hand': 0.01}


@dataclass(frozen=True)
class TrackerSettings:
    """The tracker node's settings fixed at start (see :func:`declare_settings` for each one's meaning).

    Attributes:
        kinds: One person's targets (:func:`~human_tracker.vision.people.persons.kinds_of`); the first
            is the primary kind (``pose``, ``contour``, ``status``).
    """

    target: str
    hands: int
    kinds: tuple[str, ...]
    max_people: int
    id_hold_frames: int
    template_file: str
    num_points: int
    init_box: tuple[float, float, float, float] | None
    motion_input: str
    skin_input: bool
    depth_input: bool
    fit_residual_gain: float
    image_rectified: bool
    max_pending: int
    status_period: float
    publish_tf: bool
    publish_faces: bool
    frame_prefix: str
    face_confirm_frames: int


def declare_settings(node: Any) -> TrackerSettings:
    """Declare the tracker node's own parameters (besides the bound constants) and read the ones
    fixed at start.

    Raises:
        ValueError: A value out of its choices (``target``, ``motion_input``, ``init_box``).
    """
    target = declare(
        node,
        'target',
        'head',
        'What to track: head (head-and-shoulders), hand (open or closed) or person (a head and hands, each with '
        'its id on targets).',
        read_only=True,
    )
    hands = declare(node, 'hands', 1, "With target person: a person's hands followed.", low=0, high=2, read_only=True)
    max_people = declare(
        node, 'max_people', 1, 'With target person: the most people followed at once.', low=1, high=10, read_only=True
    )
    # Read on every frame: a behaviour names the person it talks to once it has seen their id.
    declare(
        node,
        'primary_id',
        0,
        'With target person: the id of the head pose, contour and status follow while it is followed; 0 (or '
        "the id not followed): the head nearest the image's centre.",
        low=0,
        high=2**31 - 1,
    )
    id_hold_frames = declare(
        node,
        'id_hold_frames',
        15,
        "With target person: frames a LOST target's id is held; taken up again near where it was, it gets it back.",
        low=0,
        high=1000,
        read_only=True,
    )
    kinds = kinds_of(target, hands)
    template_file = declare(
        node,
        'template_file',
        '',
        'JSON template, or open_hand, closed_hand, head_and_shoulders, for the built-in one (empty: built-in).',
        read_only=True,
    )
    num_points = declare(
        node, 'num_points', 48, 'N, measurement points along the spline (§2.3).', low=4, high=1024, read_only=True
    )
    box = [
        float(v)
        for v in declare(
            node,
            'init_box',
            [0.0, 0.0, 0.0, 0.0],
            'Box x, y, w, h (pixels) of the target in the first frame; zeros: start from motion.',
            read_only=True,
        )
    ]
    if len(box) != 4 or min(box[2:]) < 0:
        raise ValueError(f'init_box must be [x, y, w >= 0, h >= 0], got {box}')
    declare(
        node,
        'target_width',
        TARGET_WIDTHS[kinds[0]],
        'Physical width of the head (or hand), metres: depth from scale (a person: the head; its hand '
        f'{TARGET_WIDTHS["hand"]}).',
        low=0.01,
        high=2.0,
    )
    motion_input = declare(
        node,
        'motion_input',
        'none',
        'Motion cue topic: none, foreground (background_node) or motion (optical_flow_node).',
        read_only=True,
    )
    if motion_input not in MOTION_INPUTS:
        raise ValueError(f'motion_input must be one of {", ".join(MOTION_INPUTS)}, got {motion_input!r}')
    skin_input = declare(node, 'skin_input', False, 'Subscribe the skin labels of skin_node (§3.2).', read_only=True)
    declare(
        node,
        'match_timeout',
        0.25,
        'Seconds a frame waits for its masks (motion, skin) before it is tracked without.',
        low=0.0,
        high=10.0,
    )
    fit_residual_gain = declare(
        node,
        'fit_residual_gain',
        FIT_RESIDUAL_GAIN,
        "The contour's own error in the pose's covariance, in its position errors (the RMS "
        'distance from its points to the edges they found, above that of a contour on the '
        'outline): across the optical axis, and the same share of the distance along the ray.',
        low=0.0,
        high=100.0,
        read_only=True,
    )
    image_rectified = declare(
        node,
        'image_rectified',
        False,
        'The image is rectified (image_rect): rays through camera_info P, no distortion; '
        'false: through K after undistorting with D.',
        read_only=True,
    )
    declare(node, 'max_gap', 1.0, 'Seconds between frames after which the target counts as lost.', low=0.0, high=3600.0)
    max_pending = declare(
        node,
        'max_pending',
        10,
        'Frames held while waiting for their masks; more are tracked without.',
        low=1,
        high=1000,
        read_only=True,
    )
    status_period = declare(
        node,
        'status_period',
        1.0,
        'Seconds between status messages while the state stays the same (each change is sent at once).',
        low=0.05,
        high=60.0,
        read_only=True,
    )
    depth_input = declare(
        node,
        'depth_input',
        False,
        'Subscribe depth (registered to the image, 16UC1 mm or 32FC1 m): the distance from it, not from the scale.',
        read_only=True,
    )
    declare(
        node,
        'surface_to_centre',
        SURFACE_TO_CENTRE[kinds[0]],
        "Metres from the target's visible surface (what depth_input measures) back to its centre.",
        low=0.0,
        high=1.0,
    )
    publish_tf = declare(
        node,
        'publish_tf',
        True,
        "A TF frame per TRACKING target on /tf (face_<id>, hand_<id>), child of the image's frame_id.",
        read_only=True,
    )
    frame_prefix = declare(
        node, 'frame_prefix', '', "Put before each TF frame's name (face_<id>, hand_<id>).", read_only=True
    )
    publish_faces = declare(
        node,
        'publish_faces',
        True,
        'ROS4HRI (REP-155) faces: /humans/faces/tracked and /humans/faces/<id>/roi (false: another node '
        'publishes them).',
        read_only=True,
    )
    face_confirm_frames = declare(
        node,
        'face_confirm_frames',
        3,
        'Frames a head is TRACKING in a row before its face id is published on /humans/faces: a false start '
        'shorter than that never reaches a consumer.',
        low=1,
        high=1000,
        read_only=True,
    )
    return TrackerSettings(
        target=target,
        hands=hands,
        kinds=kinds,
        max_people=max_people,
        id_hold_frames=id_hold_frames,
        template_file=template_file,
        num_points=num_points,
        init_box=tuple(box) if box[2] > 0 and box[3] > 0 else None,  # type: ignore[arg-type]
        motion_input=motion_input,
        skin_input=skin_input,
        depth_input=depth_input,
        fit_residual_gain=fit_residual_gain,
        image_rectified=image_rectified,
        max_pending=max_pending,
        status_period=status_period,
        publish_tf=publish_tf,
        publish_faces=publish_faces,
        frame_prefix=frame_prefix,
        face_confirm_frames=face_confirm_frames,
    )


def start_problem(init_region: str, *, motion: bool, skin: bool) -> str | None:
    """Why a tracker without ``init_box`` whose X_0 comes from ``init_region`` can never start by
    itself with these inputs (a motion mask, skin labels), or None."""
    if (init_region == 'motion' and not motion) or (init_region == 'skin' and not skin):
        needs = 'motion_input (foreground or motion)' if init_region == 'motion' else 'skin_input: true'
        return (
            f'cannot start by itself: init_region is {init_region} but no {init_region} input; set {needs}, or init_box'
        )
    return None
