"""Algorithm parameter dataclasses bound to a node's declared ROS parameters.

Each field named by a :class:`ParameterSpec` is declared with its description and range; a
run-time change builds a new dataclass, calls its ``validate()`` and, if it passes, hands it
to the algorithm; otherwise the change is refused with the validation message.
"""

from __future__ import annotations

import array
import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from human_tracker.ros.common import declare

__all__ = ['ParameterBindings', 'ParameterSpec']


def _plain(value: Any) -> Any:
    """Array parameters arrive as lists or array.array; the dataclasses hold tuples."""
    return tuple(value) if isinstance(value, (list, tuple, array.array)) else value


@dataclass(frozen=True)
class ParameterSpec:
    """How one field of an algorithm's parameter dataclass appears as a ROS parameter.

    Attributes:
        field: Field name in the dataclass (also the ROS parameter name).
        description: What it means, with unit and the paper's symbol.
        low: Lower bound for numbers (None: no range declared).
        high: Upper bound for numbers.
        runtime: Whether it may change while the node runs.
    """

    field: str
    description: str
    low: float | None = None
    high: float | None = None
    runtime: bool = True


class ParameterBindings:
    """The dataclasses bound to ``node``'s parameters; checks and applies their run-time changes."""

    def __init__(self, node: Node) -> None:
        self.node = node
        # Each bound dataclass: its ROS names' fields, its current value, and how a change is applied.
        self._bindings: list[tuple[dict[str, str], Callable[[], Any], Callable[[Any], None]]] = []
        node.add_on_set_parameters_callback(self._on_set_parameters)

    def bind(
        self, instance: Any, specs: Sequence[ParameterSpec], apply: Callable[[Any], None], prefix: str = ''
    ) -> Any:
        """Declare ``specs`` (as ``prefix`` + field: ``hand.lost_frames``) from the dataclass
        ``instance``'s defaults; return it with the declared values.

        Run-time changes build a new instance, call its ``validate()`` and, if it passes,
        hand it to ``apply``; otherwise the change is refused with the validation message.
        """
        values = {}
        for spec in specs:
            default = getattr(instance, spec.field)
            if isinstance(default, tuple):
                default = list(default)
            value = declare(
                self.node,
                prefix + spec.field,
                default,
                spec.description,
                low=spec.low,
                high=spec.high,
                read_only=not spec.runtime,
            )
            values[spec.field] = tuple(value) if isinstance(default, list) else value
        bound = dataclasses.replace(instance, **values)
        bound.validate()
        current = {'value': bound}

        def commit(new: Any) -> None:
            current['value'] = new
            apply(new)

        fields = {prefix + spec.field: spec.field for spec in specs}
        self._bindings.append((fields, lambda: current['value'], commit))
        return bound

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        for fields, get, commit in self._bindings:
            changes = {fields[p.name]: _plain(p.value) for p in parameters if p.name in fields}
            if not changes:
                continue
            candidate = dataclasses.replace(get(), **changes)
            try:
                candidate.validate()
            except ValueError as err:
                return SetParametersResult(successful=False, reason=str(err))
            commit(candidate)
            self.node.get_logger().info(f'parameters changed: {changes}')
        return SetParametersResult(successful=True)
