"""The tracker node's parameters: the filter's and each target kind's constants (bound to the
vision dataclasses, most of them changeable at run time), and the node's own settings.

The node's settings that change at run time (``primary_id``, ``target_width``,
``surface_to_centre``, ``match_timeout``, ``max_gap``) are read where they are used, so a change
takes effect on the next frame; the others are fixed at start (read-only).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from human_tracker.ros.common import WORKING_WIDTH_DESCRIPTION, declare
from human_tracker.ros.parameter_binding import ParameterSpec
from human_tracker.vision.geometry.camera import FIT_RESIDUAL_GAIN
from human_tracker.vision.people.persons import kinds_of

__all__ = [
    'FILTER_PARAMETERS',
    'MOTION_INPUTS',
    'SURFACE_TO_CENTRE',
    'TARGET_PARAMETERS',
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

FILTER_PARAMETERS = (
    ParameterSpec('num_particles', 'P, number of particles: the most the filter uses.', 1, 100000),
    ParameterSpec(
        'min_particles',
        'Fewest particles kept; below num_particles the count follows the posterior (KLD-sampling).',
        1,
        100000,
    ),
    ParameterSpec('kld_error', 'ε of KLD-sampling: the KL divergence allowed from the true posterior.', 1e-4, 0.99),
    ParameterSpec('kld_confidence', '1-δ of KLD-sampling: the probability the divergence stays below ε.', 0.51, 0.9999),
    ParameterSpec('kld_bin', "KLD-sampling's bin: x, y, s as fractions of the scale s, θ (rad)."),
    ParameterSpec(
        'search_halfwidth', 'δ (eq. 2): pixels searched each side of a contour point along its normal.', 0.5, 500.0
    ),
    ParameterSpec('miss_penalty', 'ρ (eqs. 2-3): cost of a point with no edge within δ.', 0.0, 1e9),
    ParameterSpec(
        'search_reference_scale',
        'Scale (px) below which a contour searches δ in proportion and counts distances in its own size; 0: off.',
        0.0,
        1e6,
    ),
    ParameterSpec('likelihood_gain', 'K (eq. 1): gain of the likelihood exp(-K Σ φ).', 1e-9, 1e3),
    ParameterSpec(
        'orientation_tolerance',
        'Largest angle (rad) between an edge gradient and the contour normal for the edge to count; '
        'π/2: every edge (the paper).',
        0.01,
        float(np.pi / 2),
    ),
    ParameterSpec('velocity_damping', 'a of the AR(2) dynamics (§2.2): 0 random walk, 1 constant velocity.', 0.0, 1.0),
    ParameterSpec('process_noise', 'W (§2.2): std of x, y (px), s (fraction), θ (rad) per frame.'),
    ParameterSpec('initial_spread', 'Σ (§2.5): std of the initial cloud: x, y (px), s (fraction), θ (rad).'),
    ParameterSpec(
        'interior_weight', 'w (§3.2, > 1): non-skin inside the contour costs 1/w of skin outside.', 1.0001, 1e6
    ),
    ParameterSpec('colour_depth', 'How far inside / outside the contour skin is sampled, template units.', 0.001, 1.0),
    ParameterSpec('appearance_gain', 'λ of the appearance term exp(-λ D²) of the fused likelihood.', 0.0, 1e4),
    ParameterSpec('importance_share', 'Share of particles drawn around detections with the f/g correction.', 0.0, 1.0),
    ParameterSpec('restart_share', 'Share of particles drawn around detections without correction.', 0.0, 1.0),
    ParameterSpec('proposal_spread', 'Std of particles drawn around a detection: x, y (px), s (fraction), θ (rad).'),
    ParameterSpec(
        'detection_floor', 'Likelihood of a state far from every face found, relative to one on a face.', 1e-9, 1.0
    ),
    ParameterSpec(
        'shape_switch', "Probability a frame that a particle changes to another of the template's shapes.", 0.0, 1.0
    ),
    ParameterSpec('variant_penalty', "Cost of a particle in a variant shape (a closed hand), in ρ's.", 0.0, 1e3),
    ParameterSpec('min_scale', 'Smallest scale s: reference region width in pixels.', 1.0, 1e5),
    ParameterSpec('max_scale', 'Largest scale s: reference region width in pixels.', 1.0, 1e5),
    ParameterSpec('seed', 'Seed of the particle filter (replays are reproducible).', 0, 2**31 - 1, runtime=False),
)

TARGET_PARAMETERS = (
    ParameterSpec('likelihood', 'fused (shape of eqs. 1-4 times colour appearance) or paper (shape only).'),
    ParameterSpec('appearance_parts', 'Horizontal bands of the target region with their own histogram.', 1, 16),
    ParameterSpec('adaptation_rate', 'How fast the appearance reference follows a confident track.', 0.0, 1.0),
    ParameterSpec(
        'lost_appearance_distance',
        'Bhattacharyya distance from the reference above which a frame is weak.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'proposals',
        'faces (face detections draw particles, start and restart; needs dlib), skin (skin regions draw'
        ' particles: a hand) or off.',
        runtime=False,
    ),
    ParameterSpec('avoid_faces', 'A hand: a contour on a detected face is weak; no hypothesis there.', runtime=False),
    ParameterSpec('detect_every', 'Run the face detector on every this many frames.', 1, 100000),
    ParameterSpec('patient_every', 'Frames between face detector runs once several found no face.', 1, 100000),
    ParameterSpec('face_search_reach', 'Face sizes around the predicted face the detector looks within.', 0.5, 10.0),
    ParameterSpec('detector_thread', 'Face detector in its own thread; its faces serve the next frame.', runtime=False),
    ParameterSpec(
        'detector_wait_interval',
        'Seconds between frames above which a frame waits for its own face detector run (a slow camera).',
        0.0,
        3600.0,
    ),
    ParameterSpec(
        'box_search_reach',
        "Box widths around the contour's place a head's box is searched for by its look between faces; 0: off.",
        0.0,
        2.0,
    ),
    ParameterSpec('box_min_match', "Least normalised cross-correlation of the box's look that moves it.", -1.0, 1.0),
    ParameterSpec('box_look_rate', "Share of a matched box's grey levels blended into its look.", 0.0, 1.0),
    ParameterSpec(
        'compensate_camera', "Carry the particles with the camera's shake (as the background stage measures it)."
    ),
    ParameterSpec('estimate_camera_motion', "Without a background stage in process, measure the camera's motion here."),
    ParameterSpec('pan_smoothing', "Weight of the past in the camera's mean shift, left to the dynamics.", 0.0, 0.99),
    ParameterSpec(
        'motion_mode',
        'How motion enters the likelihood: off (eqs. 1-2), weighted (eqs. 3-4) or mask (moving edges only).',
    ),
    ParameterSpec(
        'colour_mode',
        'How skin enters: off, weighted (colour term γ of §3.2) or mask (edges near skin regions only).',
    ),
    ParameterSpec(
        'max_motion_fraction',
        'A motion mask over more of the frame than this is set aside (camera moved, light changed); 1: keep all.',
        0.01,
        1.0,
    ),
    ParameterSpec('skin_margin', 'Dilation (pixels) of skin regions in the mask colour mode.', 0, 100),
    ParameterSpec('init_region', 'Region X_0 comes from: motion or skin.'),
    ParameterSpec('init_method', 'Initialisation from the moving region: scan (§2.5.2, head) or moments (§2.5.1).'),
    ParameterSpec('upper_end_restarts', 'With moments, once started, X_0 of an elongated region at its upper end.'),
    ParameterSpec('upright_angle', 'θ_upright of the scan initialisation, rad.', -3.2, 3.2),
    ParameterSpec('min_blob_area', 'Smallest moving region (pixels) that can start or restart a track.', 1, 10_000_000),
    ParameterSpec(
        'region_closing', 'Closing radius (pixels) joining a moving silhouette before it is measured.', 0, 100
    ),
    ParameterSpec(
        'init_confidence',
        'Fraction of contour points on edges a motion hypothesis needs to start the filter.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'switch_margin',
        'How much more moving support a hypothesis elsewhere needs to restart the filter there.',
        0.0,
        1.0,
    ),
    ParameterSpec('hypothesis_samples', 'States scored around a motion hypothesis.', 1, 100000),
    ParameterSpec('hypothesis_blobs', 'With moments, how many of the largest regions give an X_0.', 1, 100),
    ParameterSpec('lost_confidence', 'Fraction of contour points on edges below which a frame is weak.', 0.0, 1.0),
    ParameterSpec(
        'lost_motion_support',
        'Fraction of contour points on the motion mask below which a frame is weak; 0: off.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'init_motion_support',
        'With a motion mask, fraction of contour points on it a hypothesis needs to start the filter.',
        0.0,
        1.0,
    ),
    ParameterSpec(
        'lost_skin_support',
        'Share of the contour interior on skin below which a frame with skin labels is weak; 0: off.',
        0.0,
        1.0,
    ),
    ParameterSpec('lost_frames', 'Consecutive weak frames after which the target is lost.', 1, 100000),
    ParameterSpec(
        'lost_fit_drop',
        "Share the edge fit may fall below the target's usual fit before a frame without a motion mask is"
        ' weak (without a mask, a change of colour is weak only with it).',
        0.0,
        1.0,
    ),
    ParameterSpec('colour_edges', 'Detect edges on the colour image (strongest channel), not on its intensity.'),
    ParameterSpec('edge_blur_sigma', 'Gaussian pre-filter of the edge detector, pixels.', 0.0, 20.0),
    ParameterSpec('canny_low', 'Canny low hysteresis threshold.', 0.0, 10000.0),
    ParameterSpec('canny_high', 'Canny high hysteresis threshold.', 0.0, 10000.0),
    ParameterSpec('working_width', WORKING_WIDTH_DESCRIPTION, 0, 100000, runtime=False),
    ParameterSpec(
        'min_target_width',
        'Working pixels a target must span: a smaller one is tracked on a less reduced frame; 0: off.',
        0.0,
        10000.0,
    ),
)


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
