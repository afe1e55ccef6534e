"""The cue stages: what turns a camera frame into its evidence, in every layout.

Each stage turns a camera frame into one cue at its working width: the motion mask (background
subtraction, §2.4.1: :func:`foreground`; optical flow, §2.4.2: :func:`flow_motion`), the skin
labels (§3.2: :func:`skin_labels`, empty on a frame without colour, with the skin classes
adapted to the tracked contour when asked) and the camera's shake (:func:`camera_shake`, the
background model's measure). Every layout measures a frame's cues with
:class:`CueStages`: a cue node its own stage, the frame path every stage.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import cv2
import numpy as np

from human_tracker.io.images import to_mono8
from human_tracker.vision.cues.background import BackgroundModel
from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.cues.optical_flow import OpticalFlow
from human_tracker.vision.cues.resolution import to_working, working_scale, working_shape
from human_tracker.vision.cues.skin import SkinSegmenter, has_colour

__all__ = [
    'MOTION_CUES',
    'CueStages',
    'Frame',
    'SkinLabels',
    'camera_shake',
    'flow_motion',
    'foreground',
    'skin_labels',
]

MOTION_CUES = ('background', 'flow', 'none')
"""The motion cue: background subtraction, optical flow, or none."""


def foreground(model: BackgroundModel, image: np.ndarray, width: int) -> np.ndarray:
    """The background model's foreground mask (``uint8``, 255 on moving pixels) of ``image``
    (grey or BGR) reduced to working ``width``; the model learns the frame."""
    return model.apply(to_working(to_mono8(image), width))


def flow_motion(
    flow: OpticalFlow,
    image: np.ndarray,
    width: int,
    camera_matrix: np.ndarray | None = None,
    angular_velocity: np.ndarray | None = None,
    dt: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Optical flow from the frame before to ``image`` reduced to working ``width``, and its
    motion mask (eqs. 3-4's γ); ``camera_matrix`` K (camera pixels) and ``angular_velocity``
    (rad/s, over ``dt`` s) compensate the camera's rotation."""
    grey = to_mono8(image)
    scale = working_scale(grey.shape[1], width)
    k = None if camera_matrix is None else np.diag([scale, scale, 1.0]) @ camera_matrix
    return flow.apply(to_working(grey, width), camera_matrix=k, angular_velocity=angular_velocity, dt=dt)


class SkinLabels(NamedTuple):
    """One frame's skin stage.

    Attributes:
        labels: The skin labels at the working width (empty on a frame without colour).
        grey: The frame has no colour: no skin can be found in it.
        adapted: The skin classes adapted to the skin inside the contour given.
    """

    labels: np.ndarray
    grey: bool
    adapted: bool


def skin_labels(
    segmenter: SkinSegmenter, image: np.ndarray, width: int, contour: np.ndarray | None = None
) -> SkinLabels:
    """The skin labels of ``image`` at working ``width``
    (:meth:`~human_tracker.vision.cues.skin.SkinSegmenter.segment`), the skin classes adapted to
    the skin inside ``contour`` (``(N, 2)``, camera pixels: the target's, a frame or two old;
    with the segmenter's ``adaptation_rate``). A frame without colour (grey) has no skin: its
    labels are empty, so that a hand is never followed on it."""
    if not has_colour(image):
        return SkinLabels(np.zeros(working_shape(image.shape, width), dtype=np.uint8), True, False)
    scale = working_scale(image.shape[1], width)
    small = to_working(image, width)
    labels = segmenter.segment(small, scale)
    if contour is None:
        return SkinLabels(labels, False, False)
    region = np.zeros(small.shape[:2], dtype=np.uint8)
    cv2.fillPoly(region, [np.round(contour * scale).astype(np.int32)], 255)
    return SkinLabels(labels, False, bool(segmenter.adapt(small, region, labels)))


def camera_shake(motion: BackgroundModel | OpticalFlow | None, frame_width: int) -> np.ndarray | None:
    """The camera's motion onto the last frame as the background model measured it (``(2, 3)``,
    in the pixels of frames ``frame_width`` wide), None without a background model."""
    return motion.camera_motion_in(frame_width) if isinstance(motion, BackgroundModel) else None


class Frame(NamedTuple):
    """One camera frame as it reaches the tracker, with what a robot knows beside it.

    Attributes:
        image: ``(H, W, 3) uint8`` BGR or ``(H, W) uint8`` grey image.
        stamp_ns: Its time, nanoseconds (None: unknown; the flow cue then has no ``dt``).
        camera_matrix: K (camera pixels) from camera_info; None: unknown.
        angular_velocity: The camera's angular velocity (rad/s, optical frame) at this frame,
            None when the camera is fixed or it is unknown; with K it compensates the flow a
            rotation induces (eqs. 3-4 on a turning head of a robot).
    """

    image: np.ndarray
    stamp_ns: int | None = None
    camera_matrix: np.ndarray | None = None
    angular_velocity: np.ndarray | None = None


@dataclass
class CueStages:
    """The cue stages of one frame path: what turns a camera frame into its evidence.

    Every layout measures its cues here: the offline command and ``pipeline`` with every stage
    of :class:`~human_tracker.vision.frame_pipeline.FramePipeline`, each cue node with its own
    stage alone.

    Attributes:
        motion: The motion stage (``MOTION_CUES``), None for none.
        skin: The skin stage, None without skin.
        motion_width: The working width the motion mask is computed at.
        skin_width: The working width the skin labels are computed at.
        grey: The last frame had no colour (no skin could be found in it).
        adapted: The skin classes adapted to the last frame's contour.
        flow: The last frame's optical flow (``(H, W, 2) float32``, working pixels per
            frame), None without the flow cue.
    """

    motion: BackgroundModel | OpticalFlow | None = None
    skin: SkinSegmenter | None = None
    motion_width: int = 320
    skin_width: int = 320
    grey: bool = field(default=False, init=False)
    adapted: bool = field(default=False, init=False)
    flow: np.ndarray | None = field(default=None, init=False, repr=False)
    _last_stamp_ns: int | None = field(default=None, init=False, repr=False)

    @classmethod
    def build(cls, cue: str, skin: SkinSegmenter | None, width: int) -> CueStages:
        """Stages with the motion ``cue`` (default parameters) and the ``skin`` segmenter, both at ``width``."""
        if cue not in MOTION_CUES:
            raise ValueError(f'cue must be one of {", ".join(MOTION_CUES)}, got {cue!r}')
        motion = BackgroundModel() if cue == 'background' else OpticalFlow() if cue == 'flow' else None
        return cls(motion, skin, width, width)

    @property
    def motion_cue(self) -> str:
        """The motion stage's name in ``MOTION_CUES``."""
        return 'background' if isinstance(self.motion, BackgroundModel) else 'flow' if self.motion else 'none'

    @property
    def adapts_skin(self) -> bool:
        """Whether the skin stage adapts its classes to the target's contour."""
        return self.skin is not None and self.skin.adaptation_rate > 0

    def measure(self, frame: Frame, contour: np.ndarray | None = None) -> Evidence:
        """The frame's evidence: its motion mask, skin labels and the camera's shake (``contour``:
        the target's, ``(N, 2)`` camera pixels, a frame old; the skin classes adapt to it)."""
        image = frame.image
        motion = None
        if isinstance(self.motion, BackgroundModel):
            motion = foreground(self.motion, image, self.motion_width)
        elif isinstance(self.motion, OpticalFlow):
            last, self._last_stamp_ns = self._last_stamp_ns, frame.stamp_ns
            dt = 0.0 if last is None or frame.stamp_ns is None else max(frame.stamp_ns - last, 0) / 1e9
            self.flow, motion = flow_motion(
                self.motion, image, self.motion_width, frame.camera_matrix, frame.angular_velocity, dt
            )
        skin = None
        if self.skin is not None:
            skin, self.grey, self.adapted = skin_labels(self.skin, image, self.skin_width, contour)
        shake = camera_shake(self.motion, image.shape[1])
        return Evidence(image, motion, skin, shake, frame.stamp_ns)

    def reset(self) -> None:
        """Forget what the stages learnt: the background, the previous frame, the skin's adaptation."""
        if self.motion is not None:
            self.motion.reset()
        if self.skin is not None:
            self.skin.reset()
        self._last_stamp_ns = None
        self.flow = None
