"""RViz markers of a tracked target: its contour in the camera's optical frame, and a label.

The contour's pixels are back-projected at the target's estimated depth (the pose's z), so
the line strip lies where the person is in 3-D (and over the image in RViz's Camera display).
Each target owns two markers in the namespace ``human_tracker/<kind>``: ids ``2 id`` (the
contour, a closed LINE_STRIP) and ``2 id + 1`` (TEXT_VIEW_FACING: kind, id and state, above
the contour). Both expire after ``lifetime`` seconds, so a node that stops leaves nothing
behind; a target that is forgotten is cleared at once with DELETEALL.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from human_tracker.vision.geometry.camera import back_project

__all__ = ['LINE_WIDTH', 'TEXT_HEIGHT', 'cleared_markers', 'target_markers']

LINE_WIDTH = 0.005
"""Width of the contour's line strip, metres."""
TEXT_HEIGHT = 0.04
"""Height of the label's capital letters, metres; the label sits one height above the contour."""

# Tracked: green; lost (the filter still has an estimate): orange.
_COLOURS = {'TRACKING': ColorRGBA(r=0.1, g=0.9, b=0.2, a=1.0), 'LOST': ColorRGBA(r=1.0, g=0.55, b=0.0, a=1.0)}


def target_markers(
    header: Any,
    contour: np.ndarray,
    depth: float,
    camera_matrix: np.ndarray,
    *,
    kind: str,
    ident: int,
    status: str,
    facing: str | None = None,
    lifetime: float = 0.5,
) -> MarkerArray:
    """The contour and label markers of one target.

    Args:
        header: std_msgs/Header of the image the estimate comes from (its optical frame).
        contour: ``(N, 2)`` contour points, pixels of that image.
        depth: The target's depth Z, metres.
        camera_matrix: ``(3, 3)`` intrinsics K of the image.
        kind: ``head`` or ``hand``: the namespace and the label's first word.
        ident: The target's id (>= 0).
        status: The tracker's state, in the label (TRACKING, LOST).
        facing: Where a head faces (toward, side, away, unknown), after the state in the
            label; None: not a head, or not followed.
        lifetime: Seconds before RViz drops the markers unless they are replaced.
    """
    points = back_project(contour, depth, camera_matrix)
    colour = _COLOURS.get(status, _COLOURS['LOST'])
    strip = _marker(header, kind, 2 * ident, Marker.LINE_STRIP, colour, lifetime)
    strip.scale.x = LINE_WIDTH
    strip.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in np.vstack([points, points[:1]])]
    label = _marker(header, kind, 2 * ident + 1, Marker.TEXT_VIEW_FACING, colour, lifetime)
    label.scale.z = TEXT_HEIGHT
    label.text = f'{kind} {ident} {status}' + ('' if facing is None else f' {facing}')
    # Above the contour's top (y points down in the optical frame), over its middle.
    label.pose.position = Point(x=float(points[:, 0].mean()), y=float(points[:, 1].min() - TEXT_HEIGHT), z=float(depth))
    return MarkerArray(markers=[strip, label])


def cleared_markers(header: Any) -> MarkerArray:
    """One DELETEALL marker: RViz drops every marker of this publisher."""
    return MarkerArray(markers=[Marker(header=header, action=Marker.DELETEALL)])


def _marker(header: Any, kind: str, ident: int, shape: int, colour: ColorRGBA, lifetime: float) -> Marker:
    marker = Marker(header=header, ns=f'human_tracker/{kind}', id=ident, type=shape, action=Marker.ADD, color=colour)
    marker.pose.orientation.w = 1.0
    seconds = int(lifetime)
    marker.lifetime = Duration(sec=seconds, nanosec=int(round((lifetime - seconds) * 1e9)))
    return marker
