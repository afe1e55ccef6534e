"""How the cues enter one target's likelihood (eqs. 2-4, §3.2, the appearance term)."""

from __future__ import annotations

from dataclasses import dataclass

from human_tracker.vision.checks import check_choices, check_within, parameter

__all__ = ['COLOUR_MODES', 'LIKELIHOODS', 'MOTION_MODES', 'CueParameters']

MOTION_MODES = ('off', 'weighted', 'mask')
COLOUR_MODES = ('off', 'weighted', 'mask')
LIKELIHOODS = ('fused', 'paper')


@dataclass(frozen=True)
class CueParameters:
    """How the cues enter the likelihood (eqs. 2-4, §3.2, the appearance term).

    Attributes:
        likelihood: ``fused`` (the shape likelihood of eqs. 1-4 times the colour appearance
            term, :mod:`~human_tracker.vision.cues.appearance`) or ``paper`` (shape only).
        appearance_parts: Horizontal bands of the target's region with their own histogram.
        adaptation_rate: How fast the appearance reference follows the target, per frame
            that is not weak (0 keeps the first frame's).
        motion_mode: ``off`` (eqs. 1-2), ``weighted`` (eqs. 3-4) or ``mask`` (edges on moving
            pixels only).
        max_motion_fraction: A motion mask covering more of the frame than this isolates
            nothing (the camera moved, the light changed): the frame is then tracked on its
            edges alone (eq. 2) and gives no hypothesis. 1 keeps every mask.
        colour_mode: ``off``, ``weighted`` (the colour term of §3.2 in the likelihood) or
            ``mask`` (edges only within ``skin_margin`` of skin: skin regions delimit the fit).
        skin_margin: Dilation, pixels, of the skin regions in the ``mask`` colour mode.
    """

    likelihood: str = parameter('fused', 'fused (shape of eqs. 1-4 times colour appearance) or paper (shape only).')
    appearance_parts: int = parameter(
        2, 'Horizontal bands of the target region with their own histogram.', low=1, high=16
    )
    adaptation_rate: float = parameter(
        0.02, 'How fast the appearance reference follows a confident track.', low=0.0, high=1.0
    )
    motion_mode: str = parameter(
        'weighted', 'How motion enters the likelihood: off (eqs. 1-2), weighted (eqs. 3-4) or mask (moving edges only).'
    )
    max_motion_fraction: float = parameter(
        0.5,
        'A motion mask over more of the frame than this is set aside (camera moved, light changed; a person '
        'filling more of the view too: raise it for close-up work); 1: keep all.',
        low=0.01,
        high=1.0,
    )
    colour_mode: str = parameter(
        'weighted', 'How skin enters: off, weighted (colour term γ of §3.2) or mask (edges near skin regions only).'
    )
    skin_margin: int = parameter(4, 'Dilation (pixels) of skin regions in the mask colour mode.', low=0, high=100)

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        check_choices(self, likelihood=LIKELIHOODS, motion_mode=MOTION_MODES, colour_mode=COLOUR_MODES)
        check_within(
            self,
            appearance_parts=(self.appearance_parts >= 1, '>= 1'),
            max_motion_fraction=(0.0 < self.max_motion_fraction <= 1.0, 'in (0, 1]'),
            skin_margin=(self.skin_margin >= 0, '>= 0'),
            adaptation_rate=(0.0 <= self.adaptation_rate <= 1.0, 'in [0, 1]'),
        )
