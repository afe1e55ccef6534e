"""Contour templates: the spline silhouettes of the paper's Fig. 1 (§2.1, §2.3).

A template lives in its own unit frame: x right, y down, origin at the centre of the
target's reference region (the head for the head-and-shoulders template), and the
reference region one unit wide. A particle's scale ``s`` is therefore the width of the
reference region in pixels, and the state ``[x, y, s, θ]`` maps template point ``p`` to
the image point ``(x, y) + s R(θ) p``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

__all__ = [
    'ContourTemplate',
    'closed_hand',
    'hand',
    'head_and_shoulders',
    'open_hand',
    'template_from_control_points',
    'load_template',
    'make_template',
    'SILHOUETTES',
    'TARGETS',
    'reference_centres',
    'transform_points',
    'fit_state',
    'fit_template',
]

# Head-and-shoulders outline, left shoulder to right shoulder over the top of the head.
# Unit frame: head 1 wide, ~1.25 high, centred on the origin.
_HEAD_AND_SHOULDERS = np.array(
    [
        [-1.75, 1.95],
        [-1.55, 1.35],
        [-1.05, 1.02],
        [-0.42, 0.88],
        [-0.30, 0.62],
        [-0.46, 0.25],
        [-0.50, -0.10],
        [-0.36, -0.48],
        [0.00, -0.63],
        [0.36, -0.48],
        [0.50, -0.10],
        [0.46, 0.25],
        [0.30, 0.62],
        [0.42, 0.88],
        [1.05, 1.02],
        [1.55, 1.35],
        [1.75, 1.95],
    ],
)
_HEAD_BOX = (-0.5, -0.63, 1.0, 1.25)

# Open right hand seen from the palm side, wrist to wrist round the thumb and the four
# fingers. Unit frame: the hand (thumb tip to little finger) one unit wide, centred on the
# origin; the spline stays open at the wrist, where the forearm continues.
_OPEN_HAND = np.array(
    [
        [-0.10, 0.80],
        [-0.16, 0.50],
        [-0.28, 0.30],
        [-0.42, 0.12],
        [-0.50, -0.02],
        [-0.43, -0.08],
        [-0.32, 0.00],
        [-0.20, 0.10],
        [-0.18, -0.10],
        [-0.21, -0.38],
        [-0.16, -0.52],
        [-0.08, -0.50],
        [-0.04, -0.36],
        [-0.01, -0.10],
        [0.02, -0.42],
        [0.06, -0.60],
        [0.14, -0.62],
        [0.18, -0.48],
        [0.18, -0.10],
        [0.21, -0.40],
        [0.26, -0.53],
        [0.33, -0.50],
        [0.35, -0.36],
        [0.34, -0.06],
        [0.38, -0.26],
        [0.43, -0.34],
        [0.49, -0.30],
        [0.50, -0.18],
        [0.47, 0.10],
        [0.42, 0.40],
        [0.34, 0.80],
    ],
)
_HAND_BOX = (-0.5, -0.62, 1.0, 1.22)

# The same hand closed (a fist, or fingers folded over the palm), in the open hand's unit
# frame: 0.8 wide and centred where the open hand's box is, so that one state draws either
# shape at the hand's size and place; wrist to wrist over the knuckles.
_CLOSED_HAND = np.array(
    [
        [-0.24, 0.85],
        [-0.27, 0.55],
        [-0.36, 0.31],
        [-0.40, 0.02],
        [-0.37, -0.22],
        [-0.26, -0.35],
        [-0.11, -0.40],
        [0.05, -0.40],
        [0.22, -0.36],
        [0.34, -0.26],
        [0.40, -0.09],
        [0.40, 0.13],
        [0.34, 0.35],
        [0.26, 0.55],
        [0.22, 0.85],
    ],
)


@dataclass(frozen=True)
class ContourTemplate:
    """A silhouette sampled at measurement points (§2.3: points uniform along the spline).

    Attributes:
        name: Short name (``head``, ``hand``, or a file stem).
        points: ``(N, 2) float64``, template units, the measurement points ``x(j)``.
        normals: ``(N, 2) float64``, unit normals at the points (pointing outwards).
        reference_box: ``(x, y, w, h)`` of the reference region in template units; the
            tracker reports this box, so it compares with head / hand ground truth.
        closed: Whether the spline is a closed curve.
        variants: Other silhouettes of the same target (a hand closed as well as open), with
            as many points, in this template's unit frame and reported through its reference
            region: each particle carries which shape it draws (a mixed state, Isard & Blake,
            ECCV 1998).
    """

    name: str
    points: np.ndarray
    normals: np.ndarray
    reference_box: tuple[float, float, float, float]
    closed: bool = False
    variants: tuple[ContourTemplate, ...] = ()

    def __post_init__(self) -> None:
        for variant in self.variants:
            if variant.points.shape != self.points.shape:
                raise ValueError(f'{variant.name!r} has {variant.num_points} points, {self.name!r} {self.num_points}')

    @property
    def num_points(self) -> int:
        """Number of measurement points N."""
        return int(self.points.shape[0])

    @property
    def shapes(self) -> tuple[ContourTemplate, ...]:
        """This silhouette and its variants; a particle's shape label indexes it."""
        return (self, *self.variants)


def template_from_control_points(
    control_points: np.ndarray,
    num_points: int,
    reference_box: tuple[float, float, float, float],
    *,
    name: str = 'custom',
    closed: bool = False,
) -> ContourTemplate:
    """Fit a cubic spline through control points and sample it uniformly by arc length.

    Args:
        control_points: ``(M, 2)`` points the spline passes through, template units.
        num_points: N, the number of measurement points to sample (>= 4).
        reference_box: ``(x, y, w, h)`` of the reference region, template units.
        name: Name of the template.
        closed: Treat the curve as closed (periodic spline).

    Returns:
        The sampled template with outward unit normals.
    """
    control = np.asarray(control_points, dtype=np.float64)
    if control.ndim != 2 or control.shape[1] != 2 or control.shape[0] < 4:
        raise ValueError(f'control_points must be (M>=4, 2), got shape {control.shape}')
    if num_points < 4:
        raise ValueError(f'num_points must be >= 4, got {num_points}')
    if closed and not np.allclose(control[0], control[-1]):
        control = np.vstack([control, control[:1]])
    # Imported here: scipy.interpolate takes half a second to import, which a node answering
    # --help, or one that never builds a template, need not pay.
    from scipy.interpolate import splev, splprep

    tck, _ = splprep(control.T, s=0.0, per=int(closed), k=3)
    dense = np.linspace(0.0, 1.0, 4000)
    xy = np.stack(splev(dense, tck), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    # Uniform in arc length, as the paper asks; a closed curve must not repeat its start.
    targets = np.linspace(0.0, arc[-1], num_points, endpoint=not closed)
    u = np.interp(targets, arc, dense)
    points = np.stack(splev(u, tck), axis=1)
    tangents = np.stack(splev(u, tck, der=1), axis=1)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    normals = np.stack([tangents[:, 1], -tangents[:, 0]], axis=1)
    # Orient normals away from the reference region's centre so "outwards" is well defined.
    box_centre = np.array([reference_box[0] + reference_box[2] / 2, reference_box[1] + reference_box[3] / 2])
    flip = np.einsum('ij,ij->i', normals, points - box_centre) < 0
    if np.count_nonzero(flip) > num_points // 2:
        normals = -normals
    return ContourTemplate(name, points, normals, tuple(float(v) for v in reference_box), closed)


def head_and_shoulders(num_points: int = 48) -> ContourTemplate:
    """The head-and-shoulders template of Fig. 1 (an open spline), head one unit wide."""
    return template_from_control_points(_HEAD_AND_SHOULDERS, num_points, _HEAD_BOX, name='head_and_shoulders')


def open_hand(num_points: int = 48) -> ContourTemplate:
    """The hand template of Fig. 1 (an open spline round an open hand), hand one unit wide."""
    return template_from_control_points(_OPEN_HAND, num_points, _HAND_BOX, name='open_hand')


def closed_hand(num_points: int = 48) -> ContourTemplate:
    """A closed hand (a fist) in the open hand's unit frame, reported through its hand box."""
    return template_from_control_points(_CLOSED_HAND, num_points, _HAND_BOX, name='closed_hand')


def hand(num_points: int = 48) -> ContourTemplate:
    """The built-in hand: the open hand of Fig. 1, or closed.

    A hand waved or held before a robot is as often closed as open, and moving fast it blurs
    into a blob that the open hand's fingers do not fit. On the real ``hand2`` (twenty seeds
    from the first box) the open hand alone holds it on 0.41 of the frames.
    """
    return replace(open_hand(num_points), variants=(closed_hand(num_points),))


def load_template(path: str | Path, num_points: int = 48) -> ContourTemplate:
    """Load a template from a JSON file.

    The file holds ``{"control_points": [[x, y], ...], "reference_box": [x, y, w, h],
    "closed": false}`` in template units (reference region about one unit wide).

    Raises:
        ValueError: The file is missing, unreadable or malformed; the message says which.
    """
    path = Path(path)
    try:
        spec = json.loads(path.read_text())
        control = np.asarray(spec['control_points'], dtype=np.float64)
        box = tuple(float(v) for v in spec['reference_box'])
        closed = bool(spec.get('closed', False))
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise ValueError(f'cannot load template {path}: {err}') from err
    if len(box) != 4 or box[2] <= 0 or box[3] <= 0:
        raise ValueError(f'template {path}: reference_box must be [x, y, w>0, h>0], got {box}')
    return template_from_control_points(control, num_points, box, name=path.stem, closed=closed)


def transform_points(points: np.ndarray, state: np.ndarray) -> np.ndarray:
    """Map template points into the image for one state ``[x, y, s, θ]``.

    Args:
        points: ``(N, 2)`` template units.
        state: ``(4,)`` x, y in pixels, s in pixels per unit, θ in radians.

    Returns:
        ``(N, 2) float64`` image points in pixels.
    """
    x, y, s, theta = (float(v) for v in state[:4])
    c, si = np.cos(theta), np.sin(theta)
    rot = np.array([[c, -si], [si, c]])
    return points @ rot.T * s + np.array([x, y])


TARGETS = {'head': head_and_shoulders, 'hand': hand}
"""Built-in templates by target name."""

SILHOUETTES = {'head_and_shoulders': head_and_shoulders, 'open_hand': open_hand, 'closed_hand': closed_hand}
"""Built-in single silhouettes by name, which a template file's place takes (``open_hand``: the
paper's hand alone)."""


def reference_centres(states: np.ndarray, template: ContourTemplate) -> np.ndarray:
    """``(P, 2)`` image points (pixels) of the reference region's centre for ``(P, 4)`` states."""
    rx, ry, rw, rh = template.reference_box
    cx, cy = rx + rw / 2.0, ry + rh / 2.0
    cos, sin = np.cos(states[:, 3]), np.sin(states[:, 3])
    offsets = np.stack([cos * cx - sin * cy, sin * cx + cos * cy], axis=1)
    return states[:, :2] + states[:, 2:3] * offsets


def make_template(target: str, num_points: int = 48, template_file: str | Path = '') -> ContourTemplate:
    """The template for ``target``, or the one ``template_file`` gives: a JSON file, or the name
    of one of the :data:`SILHOUETTES`.

    Raises:
        ValueError: Unknown target, or a template file that cannot be loaded.
    """
    if str(template_file) in SILHOUETTES:
        return SILHOUETTES[str(template_file)](num_points)
    if template_file:
        return load_template(template_file, num_points)
    if target not in TARGETS:
        raise ValueError(f'unknown target {target!r}; known: {", ".join(sorted(TARGETS))} (or give a template file)')
    return TARGETS[target](num_points)


def fit_state(template_points: np.ndarray, image_points: np.ndarray) -> np.ndarray:
    """The state [x, y, s, θ] mapping template points onto image points (least squares).

    The inverse of :func:`transform_points`: recovers the state from a published contour.
    """
    p = template_points[:, 0] + 1j * template_points[:, 1]
    q = image_points[:, 0] + 1j * image_points[:, 1]
    pc, qc = p - p.mean(), q - q.mean()
    a = np.vdot(pc, qc) / np.vdot(pc, pc).real
    b = q.mean() - a * p.mean()
    return np.array([b.real, b.imag, abs(a), np.angle(a)])


def fit_template(template: ContourTemplate, image_points: np.ndarray) -> tuple[np.ndarray, ContourTemplate]:
    """The state and the shape of ``template`` (itself or a variant) a published contour
    ``(N, 2)`` is: the shape whose :func:`fit_state` leaves the smallest residual."""
    states = [fit_state(shape.points, image_points) for shape in template.shapes]
    residuals = [
        np.abs(transform_points(shape.points, state) - image_points).max()
        for shape, state in zip(template.shapes, states, strict=True)
    ]
    best = int(np.argmin(residuals))
    return states[best], template.shapes[best]
