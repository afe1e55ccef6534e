"""Before a node runs: its command line checked, ``--help`` answered, parameters it does not
declare refused.

rclpy ignores a parameter override that no node declares (a misspelt key in a parameter file
or after ``-p``): a robot's tuned value is dropped without a word. :func:`undeclared_parameters`
finds them, and the node sections of a parameter file that name no node, so that the
executables refuse to start (or, with ``strict:=false``, warn) naming the key and the
closest declared one.
"""

from __future__ import annotations

import difflib
import fnmatch
import os
import re
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import rclpy
import yaml
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

__all__ = [
    'StartError',
    'HELP_FLAGS',
    'PACKAGE_NODES',
    'without_help',
    'parameter_files',
    'check_parameter_files',
    'check_rules',
    'init_rclpy',
    'declare_strict',
    'undeclared_parameters',
    'check_configuration',
    'descriptor_range',
    'is_rclpy_parameter',
    'usage',
    'quiet_discovery',
]

HELP_FLAGS = ('-h', '--help')

PACKAGE_NODES = frozenset(
    {
        'pipeline',
        'camera_subscriber',
        'background_node',
        'optical_flow_node',
        'skin_node',
        'tracker_node',
        'bag_play',
        'video_publisher',
    }
)
"""Node names of this package's executables: one parameter file configures every layout, so a
section for a node that runs in another process is not a mistake."""

# Parameters rclpy declares or reads by itself on some nodes.
_DISCOVERY_RANGE = 'ROS_AUTOMATIC_DISCOVERY_RANGE'
_RCLPY_PARAMETERS = ('use_sim_time', 'start_type_description_service')
_RCLPY_PREFIXES = ('qos_overrides.',)


class StartError(ValueError):
    """The command line or configuration cannot start the node; the message is one line."""


def without_help(argv: Sequence[str]) -> tuple[list[str], bool]:
    """``argv`` without ``-h`` / ``--help`` (anywhere, ``--ros-args`` included) and whether one was there."""
    kept = [arg for arg in argv if arg not in HELP_FLAGS]
    return kept, len(kept) != len(argv)


def _ros_arguments(argv: Sequence[str]) -> list[str]:
    """The arguments inside ``--ros-args ... [--]`` blocks (there may be several)."""
    inside, found = False, []
    for arg in argv:
        if arg == '--ros-args':
            inside = True
        elif arg == '--' and inside:
            inside = False
        elif inside:
            found.append(arg)
    return found


def parameter_files(argv: Sequence[str]) -> list[Path]:
    """The files named by ``--params-file`` in the ROS arguments of ``argv``."""
    ros = _ros_arguments(argv)
    return [Path(ros[i + 1]) for i, arg in enumerate(ros[:-1]) if arg == '--params-file']


def check_parameter_files(argv: Sequence[str]) -> list[Path]:
    """Each ``--params-file`` exists and is a YAML mapping; returns them.

    Raises:
        StartError: One line naming the file and what is wrong with it.
    """
    files = parameter_files(argv)
    for path in files:
        _read_parameter_file(path)
    return files


def _read_parameter_file(path: Path) -> dict[str, Any]:
    """The YAML mapping of a ``--params-file``.

    Raises:
        StartError: One line naming the file and what is wrong with it.
    """
    if not path.is_file():
        raise StartError(f'parameter file {path} does not exist')
    try:
        content = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError) as err:
        raise StartError(f'parameter file {path} cannot be read: {err}') from err
    except yaml.YAMLError as err:
        where = getattr(err, 'problem_mark', None)
        line = f' (line {where.line + 1})' if where is not None else ''
        problem = getattr(err, 'problem', None) or str(err).splitlines()[0]
        raise StartError(f'parameter file {path} is not valid YAML{line}: {problem}') from err
    if not isinstance(content, dict):
        raise StartError(f'parameter file {path} must map node names to ros__parameters')
    return content


_RULE_FLAGS = ('-p', '--param', '-r', '--remap')


def check_rules(argv: Sequence[str]) -> None:
    """Each ``-p`` / ``-r`` of the ROS arguments is followed by ``NAME:=VALUE``.

    Raises:
        StartError: One line naming the rule (rcl would log its own error besides).
    """
    ros = [*_ros_arguments(argv), '']
    for flag, rule in zip(ros, ros[1:], strict=False):
        if flag in _RULE_FLAGS and ':=' not in rule:
            raise StartError(f'{flag} {rule}: expected NAME:=VALUE'.replace('  ', ' '))


def init_rclpy(argv: Sequence[str], **kwargs: Any) -> None:
    """``rclpy.init`` with ``argv``; rcl's refusal of the ROS arguments becomes a :class:`StartError`."""
    check_rules(argv)
    check_parameter_files(argv)
    try:
        rclpy.init(args=list(argv), **kwargs)
    except Exception as err:  # rclpy's RCLError, UnknownROSArgsError, RCLInvalidROSArgsError
        reason = str(err).split(', at /')[0].splitlines()[0]
        kind = 'unknown' if type(err).__name__ == 'UnknownROSArgsError' else 'invalid'
        raise StartError(f'{kind} ROS arguments: {reason}') from err


def declare_strict(node: Node) -> bool:
    """Declare ``strict`` on ``node`` (once) and return it."""
    if not node.has_parameter('strict'):
        descriptor = ParameterDescriptor(
            description='Refuse to start on a parameter no node declares, or a parameter file section that names '
            'no node (false: warn and run).',
            read_only=True,
        )
        node.declare_parameter('strict', True, descriptor)
    return bool(node.get_parameter('strict').value)


def _overrides(node: Node) -> Iterable[str]:
    # rclpy keeps the overrides that apply to the node (command line, parameter files, the
    # constructor's) in this attribute, as every rclpy since Foxy does.
    return getattr(node, '_parameter_overrides', {}).keys()


def _declared(node: Node) -> list[str]:
    return list(node.get_parameters_by_prefix('').keys())


def is_rclpy_parameter(name: str) -> bool:
    """Whether ``name`` is one of rclpy's own parameters (every node has them; none is ours)."""
    return name in _RCLPY_PARAMETERS or name.startswith(_RCLPY_PREFIXES)


def _closest(name: str, candidates: Iterable[str]) -> str:
    match = difflib.get_close_matches(name, sorted(set(candidates)), n=1, cutoff=0.6)
    return f" (did you mean '{match[0]}'?)" if match else ''


def _sections(tree: dict[str, Any], prefix: str = '') -> Iterable[str]:
    """Node names (with namespaces, ``/``-joined) of a parameter file, as rcl reads it."""
    for key, value in tree.items():
        name = f'{prefix}/{key}'.strip('/') if prefix else str(key).strip('/')
        if not isinstance(value, dict):
            continue
        if 'ros__parameters' in value:
            yield name
        else:
            yield from _sections(value, name)


def _pattern(section: str) -> re.Pattern[str]:
    """rcl's node-name wildcards: ``**`` any number of name tokens, ``*`` one."""
    parts = (re.escape(token) for token in section.split('**'))
    return re.compile('.*'.join(part.replace(r'\*', '[^/]*') for part in parts) + '$')


def _section_matches(section: str, names: Iterable[str]) -> bool:
    pattern = _pattern(section)
    return any(pattern.match(name) or fnmatch.fnmatchcase(name.rsplit('/', 1)[-1], section) for name in names)


def undeclared_parameters(nodes: Sequence[Node], argv: Sequence[str]) -> list[str]:
    """What the command line and parameter files set that no node of this process takes.

    A parameter is undeclared when every node it was given to (a ``-p`` or ``/**`` value goes
    to all) leaves it undeclared; a section of a parameter file is unmatched when it names
    neither a node of this process nor one of :data:`PACKAGE_NODES`. Each message names the
    key and the closest declared name.
    """
    problems = []
    given: dict[str, list[Node]] = {}
    for node in nodes:
        for name in _overrides(node):
            given.setdefault(name, []).append(node)
    for name, receivers in sorted(given.items()):
        if is_rclpy_parameter(name) or any(node.has_parameter(name) for node in receivers):
            continue
        declared = [p for node in receivers for p in _declared(node)]
        owner = f' for {receivers[0].get_name()}' if len(receivers) == 1 else ''
        problems.append(f"unknown parameter '{name}'{owner}{_closest(name, declared)}")
    names = {node.get_fully_qualified_name().strip('/') for node in nodes} | set(PACKAGE_NODES)
    for path in parameter_files(argv):
        for section in _sections(_read_parameter_file(path)):
            if not _section_matches(section, names):
                problems.append(
                    f"section '{section}' of {path} names no node{_closest(section.rsplit('/', 1)[-1], names)}"
                )
    return problems


def check_configuration(nodes: Sequence[Node], argv: Sequence[str]) -> None:
    """Refuse (raise :class:`StartError`) or, with ``strict:=false``, warn about what the command
    line and parameter files set that no node takes (:func:`undeclared_parameters`)."""
    strict = [declare_strict(node) for node in nodes]
    problems = undeclared_parameters(nodes, argv)
    if not problems:
        return
    if all(strict):
        raise StartError('; '.join(problems) + ' (strict:=false runs anyway)')
    for node in nodes:
        if hasattr(node, 'configuration_problems'):  # an ImageStage reports them in /diagnostics
            node.configuration_problems = problems
    logger = nodes[0].get_logger()
    for problem in problems:
        logger.warn(f'{problem}: ignored (strict is false)')


def descriptor_range(descriptor: ParameterDescriptor) -> tuple[float | None, float | None]:
    """The least and largest value a parameter's descriptor allows; (None, None): no range."""
    for ranges in (descriptor.integer_range, descriptor.floating_point_range):
        if ranges:
            return ranges[0].from_value, ranges[0].to_value
    return None, None


def _range(descriptor: ParameterDescriptor) -> str:
    low, high = descriptor_range(descriptor)
    return '' if low is None else f' [{low:g}, {high:g}]'


_HIDDEN_TOPICS = ('/rosout', '/parameter_events')
_HIDDEN_SERVICE_SUFFIXES = (
    'parameters',
    '_parameter_types',
    'parameters_atomically',
    'get_type_description',
    'change_state',
    'get_state',
    'get_available_states',
    'get_available_transitions',
    'get_transition_graph',
)


def _type_name(kind: Any) -> str:
    module = kind.__module__.split('.')[0]
    return f'{module}/{kind.__name__}'


def usage(program: str, nodes: Sequence[Node], summary: str = '') -> str:
    """The ``--help`` text: how to call ``program``, then each node's parameters and topics."""
    lines = [
        f'usage: ros2 run human_tracker {program} [--ros-args [-p NAME:=VALUE]... [--params-file FILE]...]',
        '',
    ]
    if summary:
        lines += [summary.strip(), '']
    lines += [
        'A parameter or parameter-file section that no node declares stops the start (exit 2); '
        '-p strict:=false only warns.',
    ]
    for node in nodes:
        lines += ['', f'node {node.get_fully_qualified_name()}']
        lines.append('  parameters (default, range; * changes at run time):')
        names = sorted(_declared(node))
        for name, descriptor in zip(names, node.describe_parameters(names), strict=True):
            value = node.get_parameter(name).value
            shown = list(value) if hasattr(value, 'tolist') or isinstance(value, tuple) else value
            runtime = '' if descriptor.read_only else ' *'
            text = f' - {descriptor.description}' if descriptor.description else ''
            lines.append(f'    {name} = {shown!r}{_range(descriptor)}{runtime}{text}')
        published = sorted({p.topic_name for p in node.publishers if not p.topic_name.startswith(_HIDDEN_TOPICS)})
        subscribed = sorted(
            f'{s.topic_name} ({_type_name(s.msg_type)})'
            for s in node.subscriptions
            if not s.topic_name.startswith(_HIDDEN_TOPICS)
        )
        if subscribed:
            lines.append('  subscribes: ' + ', '.join(subscribed))
        if published:
            lines.append('  publishes: ' + ', '.join(published))
        services = sorted(s.srv_name for s in node.services if not s.srv_name.endswith(_HIDDEN_SERVICE_SUFFIXES))
        if services:
            lines.append('  services: ' + ', '.join(services))
    return '\n'.join(lines)


@contextmanager
def quiet_discovery() -> Iterator[None]:
    """While inside, nodes created discover no other participant and are discovered by none
    (``--help`` and ``track --params-file`` build nodes that never run); the setting before is
    put back on exit."""
    before = os.environ.get(_DISCOVERY_RANGE)
    os.environ[_DISCOVERY_RANGE] = 'OFF'
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(_DISCOVERY_RANGE, None)
        else:
            os.environ[_DISCOVERY_RANGE] = before
