"""Algorithm parameter dataclasses bound to a node's declared ROS parameters.

Each field declared with :func:`~human_tracker.vision.checks.parameter` becomes a ROS parameter
with its default, description, range and read-only flag; a run-time change builds a new
dataclass, calls its ``validate()`` and, if it passes, hands it to the algorithm; otherwise the
change is refused with the validation message.
"""

from __future__ import annotations

import array
import dataclasses
from collections.abc import Callable
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from human_tracker.ros.common import declare
from human_tracker.vision.checks import declared_fields

__all__ = ['ParameterBindings']


def _plain(value: Any) -> Any:
    """Array parameters arrive as lists or array.array; the dataclasses hold tuples."""
    return tuple(value) if isinstance(value, (list, tuple, array.array)) else value


class ParameterBindings:
    """The dataclasses bound to ``node``'s parameters; checks and applies their run-time changes."""

    def __init__(self, node: Node) -> None:
        self.node = node
        # Each bound dataclass: its ROS names' fields, its current value, and how a change is applied.
        self._bindings: list[tuple[dict[str, str], Callable[[], Any], Callable[[Any], None]]] = []
        node.add_on_set_parameters_callback(self._on_set_parameters)

    def bind(self, instance: Any, apply: Callable[[Any], None], prefix: str = '') -> Any:
        """Declare the dataclass ``instance``'s declared fields (as ``prefix`` + field:
        ``hand.lost_frames``) with its values as defaults; return it with the declared values.

        Run-time changes build a new instance, call its ``validate()`` and, if it passes,
        hand it to ``apply``; otherwise the change is refused with the validation message.
        """
        values = {}
        declared = declared_fields(instance)
        for name, meaning in declared:
            default = getattr(instance, name)
            if isinstance(default, tuple):
                default = list(default)
            value = declare(
                self.node,
                prefix + name,
                default,
                meaning.description,
                low=meaning.low,
                high=meaning.high,
                read_only=not meaning.runtime,
            )
            values[name] = tuple(value) if isinstance(default, list) else value
        bound = dataclasses.replace(instance, **values)
        bound.validate()
        current = {'value': bound}

        def commit(new: Any) -> None:
            current['value'] = new
            apply(new)

        fields = {prefix + name: name for name, _ in declared}
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
