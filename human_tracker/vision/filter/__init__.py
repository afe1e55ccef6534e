"""The contour filter of the paper (§2): templates (splines), AR(2) dynamics, the particle filter's
resampling, the measurement along the normals and the likelihood (eqs. 1-4), proposals, and the
filter that puts them together. The lowest layer: it imports no other part of ``vision``.
"""

from __future__ import annotations

from human_tracker.vision.filter.contour_filter import (
    ContourTracker,
    TrackEstimate,
    box_from_state,
    check_box_in_image,
    state_from_box,
)
from human_tracker.vision.filter.dynamics import ar2_matrix, move_states, predict
from human_tracker.vision.filter.likelihood import TERMS, ContourModel, LikelihoodTerm, Observation, TermValue, weigh
from human_tracker.vision.filter.measurement import colour_costs, contour_costs, log_likelihood
from human_tracker.vision.filter.parameters import TrackerParameters
from human_tracker.vision.filter.particle_filter import kld_resample, systematic_resample, weighted_estimate
from human_tracker.vision.filter.proposals import detection_log_likelihood, draw_with_proposals
from human_tracker.vision.filter.templates import (
    ContourTemplate,
    closed_hand,
    fit_template,
    hand,
    head_and_shoulders,
    load_template,
    make_template,
    open_hand,
    transform_points,
)

__all__ = [
    'ContourModel',
    'ContourTemplate',
    'ContourTracker',
    'LikelihoodTerm',
    'Observation',
    'TERMS',
    'TermValue',
    'TrackEstimate',
    'TrackerParameters',
    'ar2_matrix',
    'box_from_state',
    'check_box_in_image',
    'closed_hand',
    'colour_costs',
    'contour_costs',
    'detection_log_likelihood',
    'draw_with_proposals',
    'fit_template',
    'hand',
    'head_and_shoulders',
    'kld_resample',
    'load_template',
    'log_likelihood',
    'make_template',
    'move_states',
    'open_hand',
    'predict',
    'state_from_box',
    'systematic_resample',
    'transform_points',
    'weigh',
    'weighted_estimate',
]
