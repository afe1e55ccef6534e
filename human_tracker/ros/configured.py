"""The frame path a robot's ``pipeline`` would run with a parameter file, for the offline command.

:func:`configured_pipeline` builds the ``pipeline`` node's nodes from ``--params-file`` files
and ``name=value`` overrides (``-p name:=value``), in a ROS context of their own that discovers
no one and is never spun, and hands over the frame path those nodes assembled
(:class:`~human_tracker.vision.frame_pipeline.FramePipeline`): the parameters are read,
range-checked and refused exactly as the node does it (a misspelt key is an error), and the
offline run is the robot's tracker to the last parameter.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions

from human_tracker.ros.pipeline import build_pipeline
from human_tracker.ros.startup import StartError, check_configuration, init_rclpy, quiet_discovery
from human_tracker.ros.tracker_node import TrackerNode
from human_tracker.vision.frame_pipeline import FramePipeline

__all__ = ['Configured', 'configured_pipeline', 'override_arguments']


@dataclass(frozen=True)
class Configured:
    """What the ``pipeline`` node would run.

    Attributes:
        pipeline: Its frame path.
        target: ``head``, ``hand`` or ``person``.
        init_box: Its ``init_box`` (x, y, w, h, pixels), None: start by itself.
    """

    pipeline: FramePipeline
    target: str
    init_box: tuple[float, float, float, float] | None


def override_arguments(overrides: Sequence[str]) -> list[str]:
    """``name=value`` overrides as ROS arguments (``-p name:=value``, every node that declares it).

    Raises:
        ValueError: An override is not ``name=value``.
    """
    arguments = []
    for override in overrides:
        name, equals, value = override.partition('=')
        if not equals or not name.strip():
            raise ValueError(f'--set takes name=value, got {override!r}')
        arguments += ['-p', f'{name.strip()}:={value}']
    return arguments


def configured_pipeline(parameter_files: Sequence[str | Path], overrides: Sequence[str] = ()) -> Configured:
    """The frame path of the ``pipeline`` node configured by ``parameter_files`` (in order, as
    ``--params-file``) and ``overrides`` (``name=value``, after them).

    Raises:
        ValueError: A parameter no node declares, a file section that names no node, a value
            out of range or of the wrong type, a missing or malformed file: the node's message.
    """
    argv = ['pipeline', '--ros-args', '--log-level', 'warn']
    for path in parameter_files:
        argv += ['--params-file', str(path)]
    argv += override_arguments(overrides)
    context = Context()
    nodes = []
    # The nodes are built, never spun: they discover no one and no one discovers them.
    with quiet_discovery():
        try:
            init_rclpy(argv, context=context, signal_handler_options=SignalHandlerOptions.NO)
            nodes = build_pipeline(context=context)
            check_configuration(nodes, argv)
            tracker = next(node for node in nodes if isinstance(node, TrackerNode))
            return Configured(tracker.frame_pipeline, tracker.settings.target, tracker.settings.init_box)
        except StartError as err:
            raise ValueError(str(err)) from err
        except Exception as err:  # rclpy's parameter errors: a value out of range or of the wrong type
            if type(err).__module__.startswith('rclpy'):
                raise ValueError(str(err)) from err
            raise
        finally:
            for node in nodes:
                node.destroy_node()
            context.try_shutdown()
