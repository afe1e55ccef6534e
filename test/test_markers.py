"""RViz markers of a target, by hand (no DDS: the messages only)."""

from __future__ import annotations

import numpy as np
import yaml
from conftest import REPO
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from human_tracker.io.bags import CAMERA_FRAME
from human_tracker.ros.markers import TEXT_HEIGHT, cleared_markers, target_markers


def test_the_contour_is_back_projected_at_the_depth() -> None:
    """f = 100 px, centre (50, 50), depth 2 m: pixel (150, 50) is 2 m right of the axis, (50, 0) 1 m up."""
    k = np.array([[100.0, 0.0, 50.0], [0.0, 100.0, 50.0], [0.0, 0.0, 1.0]])
    contour = np.array([[150.0, 50.0], [50.0, 0.0], [0.0, 100.0]])
    strip, label = target_markers(Header(frame_id='cam'), contour, 2.0, k, kind='hand', ident=3, status='LOST').markers
    expected = [(2.0, 0.0, 2.0), (0.0, -1.0, 2.0), (-1.0, 1.0, 2.0), (2.0, 0.0, 2.0)]
    np.testing.assert_allclose([(p.x, p.y, p.z) for p in strip.points], expected)
    assert (strip.ns, strip.id, strip.type, strip.action) == ('human_tracker/hand', 6, Marker.LINE_STRIP, Marker.ADD)
    assert (label.id, label.type, label.text) == (7, Marker.TEXT_VIEW_FACING, 'hand 3 LOST')
    # Over the contour's middle in x, one text height above its top.
    np.testing.assert_allclose((label.pose.position.x, label.pose.position.y), (1.0 / 3.0, -1.0 - TEXT_HEIGHT))
    assert strip.header.frame_id == label.header.frame_id == 'cam'
    head = target_markers(Header(), contour, 2.0, k, kind='head', ident=1, status='TRACKING', facing='away')
    assert head.markers[1].text == 'head 1 TRACKING away'
    assert (
        strip.color
        != target_markers(Header(), contour, 2.0, k, kind='hand', ident=3, status='TRACKING').markers[0].color
    )


def test_cleared_markers_delete_all() -> None:
    (marker,) = cleared_markers(Header(frame_id='cam')).markers
    assert marker.action == Marker.DELETEALL


def test_the_rviz_configuration_shows_the_tracker_topics() -> None:
    """The shipped view subscribes what tracker_node publishes, by relative name (the launch namespace)."""
    config = yaml.safe_load((REPO / 'config' / 'human_tracker.rviz').read_text())
    displays = {d['Class']: d for d in config['Visualization Manager']['Displays']}
    assert displays['rviz_default_plugins/MarkerArray']['Topic']['Value'] == 'markers'
    assert displays['rviz_default_plugins/Image']['Topic']['Value'] == 'debug_image'
    assert config['Visualization Manager']['Global Options']['Fixed Frame'] == CAMERA_FRAME
