"""Boxes, the camera (metric pose from scale and intrinsics) and depth images: geometry every
layer above the filter uses.
"""

from __future__ import annotations

from human_tracker.vision.geometry.boxes import Box, BoxRelation, box_centre, centre_within
from human_tracker.vision.geometry.camera import back_project, default_camera_matrix, metric_positions, undistort_pixels
from human_tracker.vision.geometry.depth import depth_image_to_metres, region_depth

__all__ = [
    'Box',
    'BoxRelation',
    'back_project',
    'box_centre',
    'centre_within',
    'default_camera_matrix',
    'depth_image_to_metres',
    'metric_positions',
    'region_depth',
    'undistort_pixels',
]
