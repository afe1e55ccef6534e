"""The people of the synthetic scenes, drawn from primitives (ellipses, polygons, thick lines for
the fingers), not from the tracker's templates: a head with neck and shoulders, hair and a face,
and an open hand on its forearm. States are the tracker's (x, y, s, θ): a head or hand one unit
wide in its own frame (x right, y down) is drawn ``s`` pixels wide at (x, y), turned by θ.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = [
    'BODY',
    'HAND_OUTLINE',
    'HEAD_HALF_HEIGHT',
    'HEAD_HALF_WIDTH',
    'draw_hair',
    'draw_hand',
    'draw_person',
    'head_polygon',
    'to_image',
]

HEAD_HALF_WIDTH = 0.5
HEAD_HALF_HEIGHT = 0.62
# Neck and shoulders below a head one unit wide, centred on the origin (x right, y down).
BODY = np.array(
    [
        [-0.26, 0.45],
        [0.26, 0.45],
        [0.32, 0.86],
        [1.0, 0.98],
        [1.45, 1.25],
        [1.7, 1.7],
        [1.85, 8.0],
        [-1.85, 8.0],
        [-1.7, 1.7],
        [-1.45, 1.25],
        [-1.0, 0.98],
        [-0.32, 0.86],
    ],
)


def head_polygon(state: np.ndarray) -> np.ndarray:
    x, y, s, theta = state
    axes = (max(1, int(round(HEAD_HALF_WIDTH * s))), max(1, int(round(HEAD_HALF_HEIGHT * s))))
    return cv2.ellipse2Poly((int(round(x)), int(round(y))), axes, int(round(np.degrees(theta))), 0, 360, 5)


def draw_hair(canvas: np.ndarray, state: np.ndarray, value: object, line: int) -> None:
    """Fill the hair (the top of the head's ellipse) of the head at ``state`` with ``value``."""
    x, y, s, theta = state
    axes = (int(round(HEAD_HALF_WIDTH * s)), int(round(HEAD_HALF_HEIGHT * s)))
    cv2.ellipse(canvas, (int(round(x)), int(round(y))), axes, float(np.degrees(theta)), 195, 345, value, -1, line)


def to_image(points: np.ndarray, state: np.ndarray) -> np.ndarray:
    x, y, s, theta = state
    c, si = np.cos(theta), np.sin(theta)
    rot = np.array([[c, -si], [si, c]])
    return points @ rot.T * s + np.array([x, y])


def draw_person(
    image: np.ndarray,
    state: np.ndarray,
    skin: np.ndarray,
    shirt: np.ndarray,
    gain: float,
    skin_mask: np.ndarray | None = None,
    face: bool = False,
) -> None:
    """Draw neck and shoulders, then the head with hair and face features, at ``state``
    (with ``face``, the features of :func:`_draw_face`).

    ``skin_mask``, when given, receives the face's skin pixels (255), hair and features excluded.
    """
    s = state[2]
    body = np.round(to_image(BODY, state)).astype(np.int32)
    cv2.fillPoly(image, [body], tuple(float(c) * gain for c in shirt), cv2.LINE_AA)
    targets = [(image, tuple(float(c) * gain for c in skin), cv2.LINE_AA)]
    if skin_mask is not None:
        cv2.fillPoly(skin_mask, [body], 0)
        targets.append((skin_mask, 255, cv2.LINE_8))
    hair_colour = (30 * gain, 35 * gain, 45 * gain)
    dark = (40 * gain, 40 * gain, 60 * gain)
    theta = state[3]
    features = to_image(np.array([[-0.18, -0.05], [0.18, -0.05], [0.0, 0.3]]), state)
    mx, my = features[2]
    for canvas, skin_colour, line in targets:
        hair, feature = (hair_colour, dark) if canvas is image else (0, 0)
        cv2.fillPoly(canvas, [head_polygon(state)], skin_colour, line)
        if face:
            # The hair a cap above the brows, not a wedge down to the eyes.
            cv2.fillPoly(canvas, [np.round(to_image(_HAIRLINE_CAP, state)).astype(np.int32)], hair, line)
            shade = tuple(0.75 * float(c) for c in skin_colour) if canvas is image else 0
            _draw_face(canvas, state, feature, shade, line)
            continue
        draw_hair(canvas, state, hair, line)
        for fx, fy in features[:2]:
            cv2.circle(canvas, (int(round(fx)), int(round(fy))), max(1, int(s * 0.05)), feature, -1, line)
        cv2.ellipse(
            canvas,
            (int(round(mx)), int(round(my))),
            (max(1, int(s * 0.14)), max(1, int(s * 0.04))),
            float(np.degrees(theta)),
            0,
            360,
            feature,
            -1,
            line,
        )


# The hair of a head with a face: the head's ellipse above the brows, in the head's frame (one
# unit wide, centred, y down).
_CAP_ANGLES = np.linspace(0.0, 2.0 * np.pi, 73)
_HAIRLINE_CAP = np.column_stack([HEAD_HALF_WIDTH * np.cos(_CAP_ANGLES), HEAD_HALF_HEIGHT * np.sin(_CAP_ANGLES)])
_HAIRLINE_CAP = _HAIRLINE_CAP[_HAIRLINE_CAP[:, 1] < -0.24]
# A face's features in that frame: brows (from, to), eyes (centre, half-axes), the nose's ridge
# (from, to) and nostrils (centre, half-axes), the mouth (centre, half-axes). Drawn like this, a
# face of 30 px and up is a face to dlib's HOG detector; two dots and a mouth are not.
_BROWS = (((-0.3, -0.17), (-0.07, -0.19)), ((0.07, -0.19), (0.3, -0.17)))
_EYES = (((-0.19, -0.07), (0.1, 0.045)), ((0.19, -0.07), (0.1, 0.045)))
_NOSE = ((-0.03, -0.02), (-0.05, 0.17))
_NOSTRILS = ((0.0, 0.19), (0.08, 0.035))
_MOUTH = ((0.0, 0.33), (0.15, 0.045))


def _draw_face(canvas: np.ndarray, state: np.ndarray, dark: object, shade: object, line: int) -> None:
    """Brows, eyes and mouth in ``dark``, the nose in ``shade``, on the head at ``state``."""
    s, degrees = state[2], float(np.degrees(state[3]))
    thickness = max(1, int(round(0.035 * s)))

    def at(point: tuple[float, float]) -> tuple[int, int]:
        u, v = to_image(np.array([point]), state)[0]
        return int(round(u)), int(round(v))

    def axes(half: tuple[float, float]) -> tuple[int, int]:
        return max(1, int(round(half[0] * s))), max(1, int(round(half[1] * s)))

    for start, end in _BROWS:
        cv2.line(canvas, at(start), at(end), dark, thickness, line)
    for centre, half in (*_EYES, _MOUTH):
        cv2.ellipse(canvas, at(centre), axes(half), degrees, 0, 360, dark, -1, line)
    cv2.line(canvas, at(_NOSE[0]), at(_NOSE[1]), shade, thickness, line)
    cv2.ellipse(canvas, at(_NOSTRILS[0]), axes(_NOSTRILS[1]), degrees, 0, 180, shade, thickness, line)


# An open hand one unit wide in the hand template's frame (x right, y down, hand centred
# on the origin): palm, forearm, and (base, tip, width) of the thumb and the four fingers.
_PALM = ((0.07, 0.22), (0.37, 0.38))
_FOREARM = np.array([[-0.16, 0.45], [0.40, 0.45], [0.32, 1.25], [-0.10, 1.25]])
_SLEEVE = np.array([[-0.16, 1.05], [0.36, 1.05], [0.45, 6.0], [-0.25, 6.0]])
_FINGERS = (
    ((-0.22, 0.28), (-0.42, -0.02), 0.14),
    ((-0.08, -0.02), (-0.12, -0.46), 0.13),
    ((0.09, -0.05), (0.11, -0.55), 0.13),
    ((0.26, -0.02), (0.28, -0.46), 0.12),
    ((0.39, 0.10), (0.44, -0.27), 0.11),
)


def _hand_outline_points() -> np.ndarray:
    """Points on the hand's outline above the wrist, hand frame: its ground-truth box is theirs."""
    angles = np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False)
    palm = np.stack([_PALM[0][0] + _PALM[1][0] * np.cos(angles), _PALM[0][1] + _PALM[1][1] * np.sin(angles)], 1)
    points = [palm]
    for base, tip, width in _FINGERS:
        base, tip = np.asarray(base), np.asarray(tip)
        along = (tip - base) / np.linalg.norm(tip - base)
        across = np.array([-along[1], along[0]]) * width / 2
        points.append(np.array([base + across, base - across, tip + across, tip - across, tip + along * width / 2]))
    return np.vstack(points)


HAND_OUTLINE = _hand_outline_points()


def draw_hand(
    image: np.ndarray, state: np.ndarray, skin: np.ndarray, sleeve: np.ndarray, gain: float, skin_mask: np.ndarray
) -> None:
    """Draw an open hand on its forearm at ``state``; its skin pixels go to ``skin_mask``."""
    s = state[2]
    theta = float(np.degrees(state[3]))
    palm_centre = tuple(int(round(v)) for v in to_image(np.array([_PALM[0]]), state)[0])
    palm_axes = (max(1, int(round(_PALM[1][0] * s))), max(1, int(round(_PALM[1][1] * s))))
    forearm = np.round(to_image(_FOREARM, state)).astype(np.int32)
    sleeve_polygon = np.round(to_image(_SLEEVE, state)).astype(np.int32)
    for canvas, colour, line in ((image, tuple(skin * gain), cv2.LINE_AA), (skin_mask, 255, cv2.LINE_8)):
        cv2.fillPoly(canvas, [forearm], colour, line)
        cv2.ellipse(canvas, palm_centre, palm_axes, theta, 0, 360, colour, -1, line)
        for base, tip, width in _FINGERS:
            ends = np.round(to_image(np.array([base, tip]), state)).astype(np.int32)
            thickness = max(1, int(round(width * s)))
            cv2.line(canvas, tuple(ends[0]), tuple(ends[1]), colour, thickness, line)
            cv2.circle(canvas, tuple(ends[1]), thickness // 2, colour, -1, line)
    cv2.fillPoly(image, [sleeve_polygon], tuple(sleeve * gain), cv2.LINE_AA)
    cv2.fillPoly(skin_mask, [sleeve_polygon], 0)
