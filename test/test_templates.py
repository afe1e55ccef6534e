"""Contour templates (§2.1, §2.3): uniform points, normals, state transforms."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from human_tracker.vision.filter.contour_filter import box_from_state, state_from_box
from human_tracker.vision.filter.templates import (
    closed_hand,
    fit_state,
    fit_template,
    head_and_shoulders,
    load_template,
    make_template,
    open_hand,
    template_from_control_points,
    transform_points,
)


def test_transform_points_hand_computed() -> None:
    # Point (1, 0) scaled by 10, rotated 90° (x right, y down), moved to (100, 50): (100, 60).
    points = np.array([[1.0, 0.0], [0.0, 2.0]])
    out = transform_points(points, np.array([100.0, 50.0, 10.0, np.pi / 2]))
    np.testing.assert_allclose(out, [[100.0, 60.0], [80.0, 50.0]], atol=1e-9)


def test_points_are_uniform_along_the_spline_with_unit_outward_normals() -> None:
    template = head_and_shoulders(48)
    assert template.points.shape == (48, 2) and template.normals.shape == (48, 2)
    steps = np.linalg.norm(np.diff(template.points, axis=0), axis=1)
    assert steps.std() / steps.mean() < 0.05
    np.testing.assert_allclose(np.linalg.norm(template.normals, axis=1), 1.0, atol=1e-9)
    tangents = np.gradient(template.points, axis=0)
    cosines = np.abs(np.einsum('ij,ij->i', tangents, template.normals)) / np.linalg.norm(tangents, axis=1)
    assert cosines.max() < 0.1
    top = np.argmin(template.points[:, 1])  # the top of the head: its normal points up
    assert template.normals[top, 1] < -0.9


def test_closed_template_does_not_repeat_its_start() -> None:
    circle = np.stack([np.cos(np.linspace(0, 2 * np.pi, 9)[:-1]), np.sin(np.linspace(0, 2 * np.pi, 9)[:-1])], axis=1)
    template = template_from_control_points(circle * 0.5, 16, (-0.5, -0.5, 1.0, 1.0), closed=True)
    assert np.linalg.norm(template.points[0] - template.points[-1]) > 0.1
    np.testing.assert_allclose(np.linalg.norm(template.points, axis=1), 0.5, atol=0.02)
    # Outward normals of a circle point along the radius.
    np.testing.assert_allclose(np.einsum('ij,ij->i', template.normals, template.points / 0.5), 1.0, atol=0.02)


def test_fit_state_inverts_transform_points() -> None:
    template = head_and_shoulders()
    state = np.array([312.5, 190.25, 64.0, -0.2])
    np.testing.assert_allclose(fit_state(template.points, transform_points(template.points, state)), state, atol=1e-9)


def test_box_and_state_round_trip() -> None:
    template = head_and_shoulders()
    box = (100.0, 80.0, 60.0, 75.0)  # exactly 1 : 1.25 like the head region
    state = state_from_box(box, template)
    assert state[2] == pytest.approx(60.0)
    np.testing.assert_allclose(box_from_state(state, template), box, atol=1e-9)
    with pytest.raises(ValueError, match='width and height'):
        state_from_box((0, 0, 0, 10), template)


def test_load_template_from_file_and_errors(tmp_path) -> None:
    path = tmp_path / 'blob.json'
    path.write_text(
        json.dumps(
            {
                'control_points': [[0, -0.5], [0.5, 0], [0, 0.5], [-0.5, 0]],
                'reference_box': [-0.5, -0.5, 1, 1],
                'closed': True,
            }
        )
    )
    template = load_template(path, 20)
    assert template.name == 'blob' and template.closed and template.num_points == 20
    assert make_template('head', 10, str(path)).name == 'blob'
    with pytest.raises(ValueError, match='cannot load template'):
        load_template(tmp_path / 'missing.json')
    path.write_text(json.dumps({'control_points': [[0, 0]] * 5, 'reference_box': [0, 0, -1, 1]}))
    with pytest.raises(ValueError, match='reference_box'):
        load_template(path)
    with pytest.raises(ValueError, match='unknown target'):
        make_template('elbow')


def test_hand_template_is_open_with_outward_normals() -> None:
    hand = make_template('hand', 64)
    assert hand.name == 'open_hand' and not hand.closed and hand.num_points == 64
    assert hand.points[:, 0].max() - hand.points[:, 0].min() == pytest.approx(1.0, abs=0.05)  # one unit wide
    # Outwards: up at the middle fingertip, left at the thumb's tip, right at the little finger.
    assert hand.normals[np.argmin(hand.points[:, 1]), 1] < -0.7
    assert hand.normals[np.argmin(hand.points[:, 0]), 0] < -0.7
    assert hand.normals[np.argmax(hand.points[:, 0]), 0] > 0.7
    np.testing.assert_allclose(open_hand(64).points, hand.points)


def test_the_hand_is_open_or_closed_in_one_frame() -> None:
    hand = make_template('hand', 48)
    assert [shape.name for shape in hand.shapes] == ['open_hand', 'closed_hand']
    closed = hand.variants[0]
    assert closed.num_points == 48 and closed.reference_box == hand.reference_box
    # The fist is 0.8 of the open hand's width, centred on the open hand's box, knuckles up.
    assert closed.points[:, 0].max() - closed.points[:, 0].min() == pytest.approx(0.8, abs=0.02)
    assert closed.normals[np.argmin(closed.points[:, 1]), 1] < -0.9
    # By name, a template file's place takes a single built-in silhouette: the paper's open hand.
    paper = make_template('hand', 48, 'open_hand')
    assert paper.shapes == (paper,)
    np.testing.assert_allclose(paper.points, hand.points)
    # A published contour tells its shape.
    state = np.array([40.0, 30.0, 50.0, 0.2])
    fitted, shape = fit_template(hand, transform_points(closed.points, state))
    assert shape is closed
    np.testing.assert_allclose(fitted, state)
    with pytest.raises(ValueError, match='has 24 points'):
        replace(hand, variants=(closed_hand(24),))
