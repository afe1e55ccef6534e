"""The constants of one target's tracking, by concern: how the cues combine, where faces come
in, the camera's motion, how a track starts, when it is lost, and the working frame.

Each concern is a small frozen dataclass that the code of that concern takes;
:class:`TargetParameters` is all of them, with the flat names a user sets (a YAML file, a ROS
parameter, ``--set``). Lengths and areas are in the camera's pixels; :meth:`TargetParameters.scaled`
gives them on a reduced working frame. :func:`parameters_for` gives each built-in target's
defaults.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import wraps

from human_tracker.vision.checks import check_choices, check_within, parameter, shares
from human_tracker.vision.cues.parameters import COLOUR_MODES, LIKELIHOODS, MOTION_MODES, CueParameters
from human_tracker.vision.faces.parameters import PROPOSALS, FaceParameters

__all__ = [
    'COLOUR_MODES',
    'CameraParameters',
    'CueParameters',
    'FaceParameters',
    'FrameParameters',
    'LossParameters',
    'StartParameters',
    'INIT_METHODS',
    'INIT_REGIONS',
    'LIKELIHOODS',
    'MOTION_MODES',
    'PROPOSALS',
    'TargetParameters',
    'parameters_for',
]

INIT_METHODS = ('scan', 'moments')
INIT_REGIONS = ('motion', 'skin')


@dataclass(frozen=True)
class CameraParameters:
    """Following the camera's own motion.

    Attributes:
        compensate_camera: Carry the particles with the camera's own image motion between
            frames (:mod:`~human_tracker.vision.cues.camera_motion`) before each prediction, so the
            AR(2) velocity is the target's own: the motion the background stage measured
            (:attr:`~human_tracker.vision.cues.evidence.Evidence.camera_motion`), or with
            ``estimate_camera_motion`` the tracker's own estimate.
        estimate_camera_motion: With ``compensate_camera``, estimate the motion here, away
            from the target, when none is given (a tracker fed another process's masks, or
            the flow cue): about 1.4 ms a frame at 320x240.
        pan_smoothing: Weight of the past in the running mean of the camera's shift per
            frame, in [0, 1). That mean (a pan following the person) is left to the AR(2)
            velocity, and only the rest (shake) carries the particles; 0 carries them with the
            whole motion.
    """

    compensate_camera: bool = parameter(
        True, "Carry the particles with the camera's shake (as the background stage measures it)."
    )
    estimate_camera_motion: bool = parameter(
        False, "Without a background stage in process, measure the camera's motion here."
    )
    pan_smoothing: float = parameter(
        0.5, "Weight of the past in the camera's mean shift, left to the dynamics.", low=0.0, high=0.99
    )

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        check_within(self, pan_smoothing=(0.0 <= self.pan_smoothing < 1.0, 'in [0, 1)'))


@dataclass(frozen=True)
class StartParameters:
    """How a track starts, restarts and switches: the region X_0 comes from (§2.5) and the hypotheses around it.

    Attributes:
        init_region: Where X_0 comes from: ``motion`` (the moving region) or ``skin`` (skin
            regions); when that cue is missing on a frame, the other one.
        init_method: ``scan`` (§2.5.2, head from the top of the moving region) or ``moments``
            (§2.5.1, blob moments; for a hand or a head alone).
        upper_end_restarts: With ``moments``, once the filter has been started, X_0 of a
            region at least twice as long as wide is its upper end's
            (:func:`~human_tracker.vision.track.initialisation.upper_end_state`): a hand raised with
            its forearm restarts on the hand, not on the forearm. Not for the first start.
        upright_angle: θ_upright of the scan initialisation, radians.
        min_blob_area: Smallest moving region, pixels, that can start or restart a track.
        region_closing: Radius (pixels) of the closing that joins a moving silhouette's parts
            before the region is measured (§2.5); 0 disables it.
        init_confidence: Score a motion hypothesis needs to start the filter, in [0, 1].
        init_motion_support: With a motion mask, the fraction of a hypothesis's contour
            points on it that the hypothesis needs to start the filter.
        switch_margin: How much better than the current estimate a hypothesis elsewhere must
            score to restart the filter there (never while the edges and colours of a target
            started from a box hold, with the fused likelihood).
        hypothesis_samples: States drawn around X_0 (twice ``initial_spread``) to score it.
        hypothesis_blobs: With ``moments``, how many of the largest regions each give an X_0
            (the best-fitting one wins: the hand among the skin-coloured regions).
    """

    init_region: str = parameter('motion', 'Region X_0 comes from: motion or skin.')
    init_method: str = parameter(
        'scan', 'Initialisation from the moving region: scan (§2.5.2, head) or moments (§2.5.1).'
    )
    upper_end_restarts: bool = parameter(
        False, 'With moments, once started, X_0 of an elongated region at its upper end.'
    )
    upright_angle: float = parameter(0.0, 'θ_upright of the scan initialisation, rad.', low=-3.2, high=3.2)
    min_blob_area: int = parameter(
        1000, 'Smallest moving region (pixels) that can start or restart a track.', low=1, high=10000000
    )
    region_closing: int = parameter(
        4, 'Closing radius (pixels) joining a moving silhouette before it is measured.', low=0, high=100
    )
    init_confidence: float = parameter(
        0.45, 'Fraction of contour points on edges a motion hypothesis needs to start the filter.', low=0.0, high=1.0
    )
    init_motion_support: float = parameter(
        0.0,
        'With a motion mask, fraction of contour points on it a hypothesis needs to start the filter.',
        low=0.0,
        high=1.0,
    )
    switch_margin: float = parameter(
        0.2, 'How much more moving support a hypothesis elsewhere needs to restart the filter there.', low=0.0, high=1.0
    )
    hypothesis_samples: int = parameter(128, 'States scored around a motion hypothesis.', low=1, high=100000)
    hypothesis_blobs: int = parameter(1, 'With moments, how many of the largest regions give an X_0.', low=1, high=100)

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        check_choices(self, init_method=INIT_METHODS, init_region=INIT_REGIONS)
        check_within(
            self,
            min_blob_area=(self.min_blob_area >= 1, '>= 1'),
            hypothesis_samples=(self.hypothesis_samples >= 1, '>= 1'),
            hypothesis_blobs=(self.hypothesis_blobs >= 1, '>= 1'),
            **shares(self, 'init_confidence', 'switch_margin', 'init_motion_support'),
        )


@dataclass(frozen=True)
class LossParameters:
    """When a frame is weak and a target LOST (:mod:`~human_tracker.vision.track.lifecycle`).

    Attributes:
        lost_confidence: Fraction of contour points finding an edge below which a frame is weak.
        lost_motion_support: Fraction of contour points on the motion mask below which a
            frame with a mask is weak; 0 disables the test (use it with the foreground cue).
        lost_skin_support: Share of the contour's interior on skin below which a frame with
            skin labels is weak (a hand that left the view leaves the contour on the room);
            0 disables the test.
        lost_appearance_distance: Bhattacharyya distance of the region from its reference
            above which a frame is weak, and above which a hypothesis does not start the
            filter once the target's appearance is known; within it of the face seen toward
            the camera (:class:`~human_tracker.vision.faces.facing.FaceLook`), a run that finds no
            face on a head missed it (no verdict of where the head faces).
        lost_frames: Consecutive weak frames after which the target is lost.
        lost_fit_drop: Share by which the edge fit may fall below the target's usual fit
            before a frame without a motion mask is weak; without a mask, colours unlike the
            target's appearance make a frame weak only with the fit fallen too.
    """

    lost_confidence: float = parameter(
        0.3, 'Fraction of contour points on edges below which a frame is weak.', low=0.0, high=1.0
    )
    lost_motion_support: float = parameter(
        0.0,
        'Fraction of contour points on the motion mask below which a frame is weak; 0: off (0.05 with the '
        'foreground cue: LOST when the person leaves).',
        low=0.0,
        high=1.0,
    )
    lost_skin_support: float = parameter(
        0.0,
        'Share of the contour interior on skin below which a frame with skin labels is weak; 0: off.',
        low=0.0,
        high=1.0,
    )
    lost_appearance_distance: float = parameter(
        0.5, 'Bhattacharyya distance from the reference above which a frame is weak.', low=0.0, high=1.0
    )
    lost_frames: int = parameter(5, 'Consecutive weak frames after which the target is lost.', low=1, high=100000)
    lost_fit_drop: float = parameter(
        0.25,
        "Share the edge fit may fall below the target's usual fit before a frame without a motion mask is weak"
        ' (without a mask, a change of colour is weak only with it).',
        low=0.0,
        high=1.0,
    )

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        check_within(
            self,
            lost_frames=(self.lost_frames >= 1, '>= 1'),
            **shares(
                self,
                'lost_appearance_distance',
                'lost_confidence',
                'lost_motion_support',
                'lost_skin_support',
                'lost_fit_drop',
            ),
        )


@dataclass(frozen=True)
class FrameParameters:
    """The working frame and its edges (:mod:`~human_tracker.vision.cues.resolution`,
    :mod:`~human_tracker.vision.cues.edges`).

    Attributes:
        working_width: Frames wider than this many pixels are reduced to it before the
            edges are found and the contour fitted (:mod:`~human_tracker.vision.cues.resolution`);
            0 works at full size. Every length above and in the filter's parameters stays
            in the camera's pixels.
        min_target_width: Narrowest a target may be on the working frame, pixels (its scale
            s): a smaller start box, or a target held smaller for ``lost_frames``, makes the
            tracker reduce the frame less for that track, down to not at all
            (docs/decisions/small-targets-in-wide-frames.md). 0: ``working_width`` alone decides.
        colour_edges: Detect edges on the colour image (strongest channel per pixel) when
            the frame has colour, not on its intensity.
        edge_blur_sigma: Gaussian pre-filter of the edge detector, pixels.
        canny_low: Canny low threshold.
        canny_high: Canny high threshold.
    """

    working_width: int = parameter(
        320,
        'Frames wider than this many pixels are reduced to it before processing (area averaging); masks are published'
        ' at that size. 0: full size. The same value in every stage spares the tracker resizing masks.',
        low=0,
        high=100000,
        runtime=False,
    )
    min_target_width: float = parameter(
        20.0,
        'Working pixels a target must span: a smaller one is tracked on a less reduced frame; 0: off.',
        low=0.0,
        high=10000.0,
    )
    colour_edges: bool = parameter(False, 'Detect edges on the colour image (strongest channel), not on its intensity.')
    edge_blur_sigma: float = parameter(1.5, 'Gaussian pre-filter of the edge detector, pixels.', low=0.0, high=20.0)
    canny_low: float = parameter(40.0, 'Canny low hysteresis threshold.', low=0.0, high=10000.0)
    canny_high: float = parameter(100.0, 'Canny high hysteresis threshold.', low=0.0, high=10000.0)

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        check_within(
            self,
            working_width=(self.working_width >= 0, '>= 0 (0: full size)'),
            min_target_width=(self.min_target_width >= 0, '>= 0'),
        )
        if self.canny_low < 0 or self.canny_high < self.canny_low:
            raise ValueError(f'need 0 <= canny_low <= canny_high, got {self.canny_low}, {self.canny_high}')


def _scaled_once(
    scaled: Callable[[TargetParameters, float], TargetParameters],
) -> Callable[[TargetParameters, float], TargetParameters]:
    """``scaled(factor)`` computed once per factor and kept on the (frozen) instance: the same
    object for every call at one factor (a track asks for its parameters at its scale several
    times a frame)."""

    @wraps(scaled)
    def once(self: TargetParameters, factor: float) -> TargetParameters:
        # In __dict__ directly, not a field: equality, hashing and replace() ignore it.
        memo = self.__dict__.setdefault('_scaled', {})
        if factor not in memo:
            memo[factor] = scaled(self, factor)
        return memo[factor]

    return once


@dataclass(frozen=True)
class TargetParameters(
    FrameParameters, LossParameters, StartParameters, CameraParameters, FaceParameters, CueParameters
):
    """Every constant of one target's tracking (each concern's, above), under flat names."""

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        for concern in (
            CueParameters,
            FaceParameters,
            CameraParameters,
            StartParameters,
            LossParameters,
            FrameParameters,
        ):
            concern.validate(self)

    @_scaled_once
    def scaled(self, factor: float) -> TargetParameters:
        """The same parameters on images resized by ``factor``: lengths and areas in pixels scaled."""
        if factor == 1.0:
            return self
        return replace(
            self,
            skin_margin=round(self.skin_margin * factor),
            min_blob_area=max(1, round(self.min_blob_area * factor**2)),
            region_closing=round(self.region_closing * factor),
            edge_blur_sigma=self.edge_blur_sigma * factor,
        )


def parameters_for(target: str) -> TargetParameters:
    """Defaults suited to a built-in target (docs/parameters.md lists both).

    The head starts from the top of the moving region (§2.5.2), fits intensity edges, and its
    faces draw particles. The hand starts from the moments (§2.5.1) of skin regions and fits
    colour edges (a hand is often as bright as what is behind it, but rarely the same colour);
    skin regions draw its particles, it keeps off faces, and it keeps the paper's likelihood
    (docs/decisions/hand-keeps-the-paper-likelihood.md).
    """
    if target == 'hand':
        return TargetParameters(
            init_method='moments',
            upper_end_restarts=True,
            init_region='skin',
            proposals='skin',
            avoid_faces=True,
            likelihood='paper',
            hypothesis_blobs=3,
            # A hypothesis elsewhere takes over only with much more motion support than a
            # head's: a hand stops and starts waving (docs/decisions/hand-constants.md).
            switch_margin=0.3,
            lost_skin_support=0.5,
            init_motion_support=0.25,
            # Skin-coloured wood and a bare forearm offer regions a hand-shaped contour half fits.
            init_confidence=0.6,
            colour_edges=True,
            detect_every=5,
            patient_every=20,
            # The fingers' outline needs more pixels than a head's.
            min_target_width=32.0,
        )
    return TargetParameters()
