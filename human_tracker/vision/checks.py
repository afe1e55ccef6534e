"""The parameter dataclasses' fields, each declared once (:func:`parameter`: default, meaning,
range, whether it may change at run time), and their checks (each raises ValueError naming the
parameter).

A node declares its ROS parameters from these fields, and the shipped YAML and
``docs/parameters.md`` are generated from the node's declarations: the field is the only place
a constant is described.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

__all__ = ['Declared', 'check_choices', 'check_within', 'declared_fields', 'description_of', 'parameter', 'shares']


@dataclass(frozen=True)
class Declared:
    """What a user is told of one constant.

    Attributes:
        description: Its meaning, with unit and the paper's symbol.
        low: Least value of a number (None: no range).
        high: Largest value of a number.
        runtime: Whether it may change while the node runs (False: fixed at start).
    """

    description: str
    low: float | None = None
    high: float | None = None
    runtime: bool = True


def parameter(
    default: Any, description: str, *, low: float | None = None, high: float | None = None, runtime: bool = True
) -> Any:
    """A dataclass field of an algorithm's constant: its default and :class:`Declared` meaning."""
    return field(default=default, metadata={'declared': Declared(description, low, high, runtime)})


def declared_fields(parameters: Any) -> list[tuple[str, Declared]]:
    """The declared fields of a parameter dataclass (or instance), in field order."""
    return [(f.name, f.metadata['declared']) for f in fields(parameters) if 'declared' in f.metadata]


def description_of(parameters: Any, name: str) -> str:
    """The declared meaning of the field ``name`` of a parameter dataclass (or instance)."""
    return dict(declared_fields(parameters))[name].description


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
