"""What a frame says: the cue stages (background subtraction §2.4.1, optical flow §2.4.2, skin
colour §3.2, the camera's own motion) and one frame's evidence at each working resolution
(edges, colour appearance).
"""

from __future__ import annotations

from human_tracker.vision.cues.appearance import AppearanceModel, bhattacharyya_distance, colour_bins
from human_tracker.vision.cues.background import BackgroundModel, BackgroundParameters
from human_tracker.vision.cues.camera_motion import CameraMotion, CameraShake, estimate_camera_motion
from human_tracker.vision.cues.edges import edge_map
from human_tracker.vision.cues.evidence import Cues, Evidence, FrameSettings, WorkingFrame, working_cues
from human_tracker.vision.cues.optical_flow import FlowParameters, OpticalFlow
from human_tracker.vision.cues.parameters import CueParameters
from human_tracker.vision.cues.resolution import to_working, working_scale, working_shape
from human_tracker.vision.cues.skin import SkinModel, SkinParameters, SkinSegmenter, default_skin_model, has_colour
from human_tracker.vision.cues.stages import MOTION_CUES, CueStages, Frame

__all__ = [
    'AppearanceModel',
    'BackgroundModel',
    'BackgroundParameters',
    'CameraMotion',
    'CameraShake',
    'CueParameters',
    'CueStages',
    'Cues',
    'Evidence',
    'FlowParameters',
    'Frame',
    'FrameSettings',
    'MOTION_CUES',
    'OpticalFlow',
    'SkinModel',
    'SkinParameters',
    'SkinSegmenter',
    'WorkingFrame',
    'bhattacharyya_distance',
    'colour_bins',
    'default_skin_model',
    'edge_map',
    'estimate_camera_motion',
    'has_colour',
    'to_working',
    'working_cues',
    'working_scale',
    'working_shape',
]
