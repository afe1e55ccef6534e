"""Seeded synthetic camera scenes with ground truth, for tests, demos and benchmarks.

A scene is a static camera looking at a textured, cluttered room. In a head scene a
person's head and shoulders move (translation, scale change, rotation); in a hand scene the
person stands by and waves an open hand in front of the room, the face in view; in a people
scene a second person, nearer the camera, walks across in front of the one waving. People and
hands are drawn from primitives (ellipses, polygons, thick lines for the fingers), not from
the tracker's templates, so a template only approximates the silhouette, as on real video.
Everything random comes from one seeded generator: the same spec gives the same frames.
With ``depth``, each frame also has a depth image registered to it, as an RGB-D camera gives.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import cv2
import numpy as np

from human_tracker.scenes.figures import (
    BODY,
    HAND_OUTLINE,
    HEAD_HALF_HEIGHT,
    HEAD_HALF_WIDTH,
    draw_hair,
    draw_hand,
    draw_person,
    head_polygon,
    to_image,
)
from human_tracker.vision.geometry.camera import default_camera_matrix

__all__ = ['PEOPLE_TARGETS', 'SceneSpec', 'SceneFrame', 'render_scene', 'SCENES']

PEOPLE_TARGETS = ('person_1/head', 'person_1/hand', 'person_2/head')
"""The ground-truth tracks of a people scene: the waving person's head and hand, and the head of
the person walking across."""

HEAD_WIDTH = 0.16
"""A head's physical width, metres: a head ``s`` pixels wide is ``fx HEAD_WIDTH / s`` away
(the default camera's fx)."""
HEAD_DEPTH = 0.2
"""A head's depth (nose to the back of the head), metres."""


@dataclass(frozen=True)
class SceneSpec:
    """What a synthetic scene looks like and how the person moves.

    Attributes:
        name: Scene name (the bag is named after it).
        target: What moves and is ground truth: ``head``, ``hand``, or ``people`` (the
            targets of :data:`PEOPLE_TARGETS`).
        width: Image width, pixels.
        height: Image height, pixels.
        num_frames: Number of frames.
        fps: Frame rate, Hz (sets the stamps).
        seed: Seed of every random draw of the scene.
        head_width: Mean head width, pixels (the head tracker's scale s).
        hand_width: Mean hand width (thumb to little finger), pixels (the hand tracker's s).
        clutter: Number of random shapes drawn on the background.
        head_like_clutter: Number of static head-and-shoulders-like outlines in the background.
        skin_like_clutter: Number of background shapes in skin-like colours (wood, cardboard).
        noise_sigma: Standard deviation of the additive camera noise, grey levels.
        lighting_drift: Peak relative change of the global illumination over the scene.
        amplitude: Horizontal and vertical amplitude of the motion, as fractions of the size.
        scale_change: Peak relative change of the head size (moving to and from the camera).
        max_rotation: Peak in-plane rotation θ, radians.
        pauses: Frame ranges ``[start, end)`` in which the person stands still.
        absent: Frame ranges ``[start, end)`` in which the person is out of view.
        depth: Also render a depth image per frame (head scenes).
        arrival: Frames over which the standing person of a hand or people scene steps in from
            the left to their place (0: there from the first frame).
        faces: Draw faces a face detector finds (brows, eyes, nose, mouth) instead of two dots
            and a mouth.
    """

    name: str
    target: str = 'head'
    width: int = 640
    height: int = 480
    num_frames: int = 150
    fps: float = 30.0
    seed: int = 1
    head_width: float = 70.0
    hand_width: float = 90.0
    clutter: int = 40
    head_like_clutter: int = 0
    skin_like_clutter: int = 0
    noise_sigma: float = 3.0
    lighting_drift: float = 0.0
    amplitude: tuple[float, float] = (0.28, 0.06)
    scale_change: float = 0.15
    max_rotation: float = 0.15
    pauses: tuple[tuple[int, int], ...] = ()
    absent: tuple[tuple[int, int], ...] = ()
    depth: bool = False
    arrival: int = 0
    faces: bool = False


@dataclass
class SceneFrame:
    """One rendered frame and its ground truth.

    Attributes:
        index: Frame index from 0.
        stamp_ns: Time stamp, nanoseconds.
        image: ``(H, W, 3) uint8`` BGR image.
        visible: Whether the person is in view.
        state: ``(4,)`` true [x, y, s, θ] of the target (centre pixels, width pixels, radians);
            of the waving person's head in a people scene.
        box: ``(x, y, w, h)`` pixels, axis-aligned box of the head or hand, None when absent.
        targets: Every ground-truth track's box by name (``person_1/head``, ...; None while
            out of view): the one target's under ``person_1/<target>``, a people scene's three.
        skin: ``(H, W) bool``, True on the pixels of the face and the hand (their true skin).
        depth: ``(H, W) uint16`` millimetres (0: no reading) registered to ``image``, with
            ``SceneSpec.depth``.
    """

    index: int
    stamp_ns: int
    image: np.ndarray
    visible: bool
    state: np.ndarray
    box: tuple[float, float, float, float] | None = field(default=None)
    targets: dict[str, tuple[float, float, float, float] | None] = field(default_factory=dict)
    skin: np.ndarray | None = field(default=None, repr=False)
    depth: np.ndarray | None = field(default=None, repr=False)


# Scenes first recorded at this time, so stamps are realistic and identical run to run.
_EPOCH_NS = 1_767_225_600 * 1_000_000_000


def _in_ranges(index: int, ranges: tuple[tuple[int, int], ...]) -> bool:
    return any(start <= index < end for start, end in ranges)


def _clothes(rng: np.random.Generator) -> np.ndarray:
    """Clothes darker or brighter than the room's mid-grey, as most clothing is under indoor light."""
    return rng.uniform(25, 80, size=3) if rng.random() < 0.5 else rng.uniform(175, 235, size=3)


def _background(spec: SceneSpec, rng: np.random.Generator) -> np.ndarray:
    """Textured room: smooth colour gradients, random shapes and optional head-like decoys."""
    h, w = spec.height, spec.width
    coarse = rng.uniform(60, 200, size=(6, 8, 3)).astype(np.float32)
    image = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC)
    fine = rng.normal(0, 8, size=(h // 4, w // 4, 3)).astype(np.float32)
    image += cv2.resize(fine, (w, h), interpolation=cv2.INTER_LINEAR)
    image = np.clip(image, 0, 255).astype(np.uint8)
    for _ in range(spec.clutter):
        colour = tuple(int(c) for c in rng.integers(20, 236, size=3))
        kind = rng.integers(0, 3)
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        size = int(rng.integers(10, 90))
        if kind == 0:
            cv2.rectangle(image, (x, y), (x + size, y + int(rng.integers(10, 90))), colour, -1, cv2.LINE_AA)
        elif kind == 1:
            axes = (size // 2 + 3, int(rng.integers(5, 45)))
            cv2.ellipse(image, (x, y), axes, float(rng.uniform(0, 180)), 0, 360, colour, -1, cv2.LINE_AA)
        else:
            end = (x + int(rng.integers(-120, 120)), y + int(rng.integers(-120, 120)))
            cv2.line(image, (x, y), end, colour, int(rng.integers(2, 6)), cv2.LINE_AA)
    # Decoys stand where the person walks (same height, spread across the path), so that a
    # tracker fitting edges alone can slide onto them when the person passes by.
    for index in range(spec.head_like_clutter):
        across = (index + 0.5) / spec.head_like_clutter
        decoy = np.array(
            [
                w * (0.5 + spec.amplitude[0] * 1.6 * (across - 0.5) * 2 + rng.uniform(-0.03, 0.03)),
                h * (0.38 + rng.uniform(-0.04, 0.04)),
                spec.head_width * rng.uniform(0.85, 1.15),
                rng.uniform(-0.1, 0.1),
            ]
        )
        draw_person(image, decoy, rng.uniform(60, 200, size=3), _clothes(rng), 1.0)
    # Wood, cardboard, terracotta: colours the skin classes accept, shaped unlike a hand.
    for _ in range(spec.skin_like_clutter):
        colour = tuple(float(c) for c in _skin_tone(rng) * rng.uniform(0.8, 1.1))
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        if rng.random() < 0.5:
            corner = (x + int(rng.integers(30, 120)), y + int(rng.integers(20, 90)))
            cv2.rectangle(image, (x, y), corner, colour, -1, cv2.LINE_AA)
        else:
            axes = (int(rng.integers(15, 60)), int(rng.integers(10, 40)))
            cv2.ellipse(image, (x, y), axes, float(rng.uniform(0, 180)), 0, 360, colour, -1, cv2.LINE_AA)
    return image


def _skin_tone(rng: np.random.Generator) -> np.ndarray:
    """A skin colour, B, G, R."""
    return np.array([95.0, 135.0, 200.0]) + rng.uniform(-15, 15, size=3)


def _trajectory(spec: SceneSpec, motion_time: float) -> np.ndarray:
    """True head state after ``motion_time`` seconds of motion (time stops during pauses)."""
    t = motion_time
    cx = spec.width * (0.5 + spec.amplitude[0] * np.sin(2 * np.pi * t / 5.0))
    cy = spec.height * (0.38 + spec.amplitude[1] * np.sin(2 * np.pi * t / 2.3 + 0.7))
    s = spec.head_width * (1.0 + spec.scale_change * np.sin(2 * np.pi * t / 4.1 + 1.3))
    theta = spec.max_rotation * np.sin(2 * np.pi * t / 3.3)
    return np.array([cx, cy, s, theta])


def _hand_trajectory(spec: SceneSpec, motion_time: float) -> np.ndarray:
    """True hand state after ``motion_time`` seconds of waving (time stops during pauses)."""
    t = motion_time
    cx = spec.width * (0.6 + spec.amplitude[0] * np.sin(2 * np.pi * t / 2.0))
    cy = spec.height * (0.42 + spec.amplitude[1] * np.sin(2 * np.pi * t / 1.3 + 0.7))
    s = spec.hand_width * (1.0 + spec.scale_change * np.sin(2 * np.pi * t / 3.1 + 1.3))
    # The hand turns about the wrist as it waves: most tilted at the ends of the swing.
    theta = spec.max_rotation * np.sin(2 * np.pi * t / 2.0)
    return np.array([cx, cy, s, theta])


def _walker(spec: SceneSpec, index: int) -> np.ndarray:
    """The head state of a people scene's second person, who walks across the whole view from
    right to left, nearer the camera (a fifth larger), nodding a little as they step."""
    progress = index / max(spec.num_frames - 1, 1)
    cx = spec.width * (1.15 - 1.3 * progress)
    cy = spec.height * (0.42 + 0.01 * np.sin(2 * np.pi * index / 15.0))
    return np.array([cx, cy, 1.2 * spec.head_width, 0.05 * np.sin(2 * np.pi * index / 30.0)])


def _depth_image(spec: SceneSpec, state: np.ndarray | None, rng: np.random.Generator) -> np.ndarray:
    """What an RGB-D camera sees, millimetres: the room from 3.5 m (top) to 2.5 m (bottom: the
    floor comes closer), the person (``state``, None when away) with the head's centre at the
    distance its width says, noise growing with the square of the distance (σ = 1.5 mm at 1 m), and holes: 3 % of the
    pixels, and half of the hair's (it absorbs the projector's light)."""
    depth = np.repeat(np.linspace(3.5, 2.5, spec.height, dtype=np.float64)[:, None], spec.width, axis=1)
    hair = np.zeros(depth.shape, np.uint8)
    if state is not None:
        distance = default_camera_matrix(spec.width, spec.height)[0, 0] * HEAD_WIDTH / state[2]
        person = np.zeros(depth.shape, np.uint8)
        cv2.fillPoly(person, [np.round(to_image(BODY, state)).astype(np.int32)], 1)
        depth[person > 0] = distance + 0.05  # the shoulders a little behind the face
        head = np.zeros(depth.shape, np.uint8)
        cv2.fillPoly(head, [head_polygon(state)], 1)
        # The face bulges towards the camera: an ellipsoid HEAD_DEPTH / 2 deep around the head's
        # centre, which lies `distance` away.
        x, y, s, _ = state
        rows, columns = np.nonzero(head)
        across = ((columns - x) / (HEAD_HALF_WIDTH * s)) ** 2 + ((rows - y) / (HEAD_HALF_HEIGHT * s)) ** 2
        depth[rows, columns] = distance - 0.5 * HEAD_DEPTH * np.sqrt(np.clip(1.0 - across, 0.0, 1.0))
        draw_hair(hair, state, 1, cv2.LINE_8)
    depth += rng.normal(0.0, 1.0, depth.shape) * 0.0015 * depth**2
    holes = (rng.random(depth.shape) < 0.03) | ((hair > 0) & (rng.random(depth.shape) < 0.5))
    depth[holes] = 0.0
    return np.round(depth * 1000.0).astype(np.uint16)


def _box(points: np.ndarray) -> tuple[float, float, float, float]:
    x0, y0 = points.min(axis=0)
    x1, y1 = points.max(axis=0)
    return float(x0), float(y0), float(x1 - x0), float(y1 - y0)


def render_scene(spec: SceneSpec) -> Iterator[SceneFrame]:
    """Render the frames of ``spec`` in order; deterministic for a given spec."""
    if spec.target not in ('head', 'hand', 'people'):
        raise ValueError(f'scene target must be head, hand or people, got {spec.target!r}')
    rng = np.random.default_rng(spec.seed)
    background = _background(spec, rng)
    skin = _skin_tone(rng)
    shirt = _clothes(rng)
    hand_scene = spec.target in ('hand', 'people')
    sleeve = _clothes(rng) if hand_scene else shirt
    # Drawn after the single-person scenes' draws: their frames stay as they were.
    walker_skin, walker_shirt = (_skin_tone(rng), _clothes(rng)) if spec.target == 'people' else (skin, shirt)
    noise_rng = np.random.default_rng(spec.seed + 1)
    depth_rng = np.random.default_rng(spec.seed + 2)  # its own: the colour frames stay as without depth
    motion_time = 0.0
    for index in range(spec.num_frames):
        if index > 0 and not _in_ranges(index, spec.pauses):
            motion_time += 1.0 / spec.fps
        visible = not _in_ranges(index, spec.absent)
        # Lighting drifts on the whole scene, person included, as a slow gain change.
        gain = 1.0 + spec.lighting_drift * np.sin(2 * np.pi * index / max(spec.num_frames, 1))
        frame = np.clip(background.astype(np.float32) * gain, 0, 255).astype(np.uint8)
        skin_mask = np.zeros(frame.shape[:2], dtype=np.uint8)
        if hand_scene:
            # The person stands to the side, swaying a little, and waves in front of the room.
            # Stepping in over `arrival` frames from 0.14 of the width to the left of their place.
            step = 0.14 * max(1.0 - index / spec.arrival, 0.0) if spec.arrival else 0.0
            person = np.array(
                [spec.width * (0.22 - step + 0.01 * np.sin(motion_time)), spec.height * 0.3, spec.head_width, 0.0]
            )
            draw_person(frame, person, skin, shirt, gain, skin_mask, spec.faces)
            state = _hand_trajectory(spec, motion_time)
            if visible:
                draw_hand(frame, state, skin, sleeve, gain, skin_mask)
            box = _box(to_image(HAND_OUTLINE, state)) if visible else None
            targets = {'person_1/hand': box}
            if spec.target == 'people':
                walker = _walker(spec, index)
                draw_person(frame, walker, walker_skin, walker_shirt, gain, skin_mask, spec.faces)
                in_view = 0.0 <= walker[0] < spec.width
                targets = {
                    'person_1/head': _box(head_polygon(person)),
                    'person_1/hand': box,
                    'person_2/head': _box(head_polygon(walker)) if in_view else None,
                }
                state, box = person, targets['person_1/head']
        else:
            state = _trajectory(spec, motion_time)
            if visible:
                draw_person(frame, state, skin, shirt, gain, skin_mask, spec.faces)
            box = _box(head_polygon(state)) if visible else None
            targets = {'person_1/head': box}
        noisy = frame.astype(np.float32) + noise_rng.normal(0, spec.noise_sigma, size=frame.shape)
        image = np.clip(noisy, 0, 255).astype(np.uint8)
        stamp_ns = _EPOCH_NS + int(round(index * 1e9 / spec.fps))
        depth = None
        if spec.depth:
            depth = _depth_image(spec, state if visible and not hand_scene else None, depth_rng)
        yield SceneFrame(index, stamp_ns, image, visible, state, box, targets, skin_mask > 0, depth)


SCENES: dict[str, SceneSpec] = {
    spec.name: spec
    for spec in (
        SceneSpec(name='head_basic', seed=1, num_frames=120, clutter=60, noise_sigma=2.0),
        # Head-and-shoulders decoys along the person's path: edges alone are not enough. The
        # person steps into view at frame 10 (the camera sees the room first).
        SceneSpec(
            name='head_cluttered',
            seed=2,
            num_frames=120,
            clutter=30,
            head_like_clutter=5,
            noise_sigma=2.0,
            absent=((0, 10),),
        ),
        # Empty room, the person appears still, starts moving at frame 30, stops from 75 to
        # 105, under a slow lighting drift.
        SceneSpec(
            name='head_stop_and_go',
            seed=3,
            num_frames=120,
            clutter=40,
            noise_sigma=2.0,
            lighting_drift=0.12,
            absent=((0, 10),),
            pauses=((0, 30), (75, 105)),
        ),
        # The person leaves the view for frames 45-75 and comes back.
        SceneSpec(name='head_leave_return', seed=4, num_frames=120, clutter=40, noise_sigma=2.0, absent=((45, 75),)),
        # A hand waving in front of a room with skin-coloured furniture, the face in view.
        SceneSpec(
            name='hand_wave',
            target='hand',
            seed=5,
            num_frames=120,
            clutter=40,
            skin_like_clutter=8,
            noise_sigma=2.0,
            amplitude=(0.16, 0.05),
            scale_change=0.1,
            max_rotation=0.3,
        ),
        # More skin-coloured clutter, a lighting drift, and the hand holds still (frames 60-85).
        SceneSpec(
            name='hand_cluttered',
            target='hand',
            seed=6,
            num_frames=120,
            clutter=30,
            skin_like_clutter=16,
            noise_sigma=2.0,
            lighting_drift=0.1,
            amplitude=(0.16, 0.05),
            scale_change=0.1,
            max_rotation=0.3,
            pauses=((60, 85),),
        ),
        # Two people: one steps in (frames 0-20) and waves a hand, the other walks across in front
        # of both (in view on frames 17-140). Their faces are faces to the detector.
        SceneSpec(
            name='people_crossing',
            target='people',
            seed=7,
            num_frames=150,
            clutter=40,
            skin_like_clutter=4,
            noise_sigma=2.0,
            amplitude=(0.12, 0.05),
            scale_change=0.1,
            max_rotation=0.3,
            arrival=20,
            faces=True,
        ),
    )
}
"""The scenes whose bags ship in ``bags/``, by name."""
