"""Range checks of the parameter dataclasses: each raises ValueError naming the parameter."""

from __future__ import annotations

__all__ = ['check_choices', 'check_within', 'shares']


def check_choices(parameters: object, **allowed: tuple[str, ...]) -> None:
    """Each named field of ``parameters`` is one of its allowed values."""
    for name, choices in allowed.items():
        if getattr(parameters, name) not in choices:
            raise ValueError(f'{name} must be one of {", ".join(choices)}, got {getattr(parameters, name)!r}')


def check_within(parameters: object, **checks: tuple[bool, str]) -> None:
    """Each named check holds (``(ok, what is allowed)``)."""
    for name, (ok, allowed) in checks.items():
        if not ok:
            raise ValueError(f'{name} must be {allowed}, got {getattr(parameters, name)}')


def shares(parameters: object, *names: str) -> dict[str, tuple[bool, str]]:
    """The checks that each named field is a share, in [0, 1]."""
    return {name: (0.0 <= getattr(parameters, name) <= 1.0, 'in [0, 1]') for name in names}
