"""Running a package executable's nodes: start, ``--help``, signals and a clean stop."""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import rclpy
import rclpy.logging
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from human_tracker.ros.common import init_without_signal_handlers, shutdown, spin_until, stop_on_signals
from human_tracker.ros.stage import ImageStage
from human_tracker.ros.startup import (
    StartError,
    check_configuration,
    declare_strict,
    quiet_discovery,
    usage,
    without_help,
)

__all__ = ['described', 'run_nodes', 'spin_node']


def run_nodes(
    build: Callable[[], list[Node]],
    args: list[str] | None = None,
    *,
    name: str = 'node',
    run: Callable[[list[Node]], None] | None = None,
    summary: str = '',
) -> int:
    """Init rclpy, build the nodes, run them until SIGINT or SIGTERM; return the exit code.

    By default the nodes are spun in this thread. With ``run``, ``run(nodes)`` works in this
    thread while they are spun in another (their timers, services and parameters keep
    answering) until it returns.

    ``-h`` / ``--help`` prints the nodes' parameters (defaults, ranges, descriptions) and
    topics, with ``summary`` above them, and exits 0: the nodes are built with discovery off
    and never spun. Malformed ROS arguments, a missing or unparseable parameter file, a
    parameter or parameter-file section that no node declares (unless ``strict:=false``: a
    warning, also in ``/diagnostics``), a ValueError or an rclpy parameter error while
    building or running (a value out of range or of the wrong type, a missing file): one line
    with the reason and exit code 2, no traceback.

    A signal stops the spinning between two callbacks (see
    :func:`~human_tracker.ros.common.stop_on_signals`); the nodes are then destroyed and rclpy
    shut down here, in order. Ctrl-C exits with 0.
    """
    argv, wants_help = without_help(sys.argv if args is None else args)
    if wants_help:
        return _print_usage(build, argv, name, summary)
    try:
        init_without_signal_handlers(argv)
    except StartError as err:
        print(f'{name}: cannot start: {err}', file=sys.stderr)
        return 2
    nodes: list[Node] = []
    executor = SingleThreadedExecutor()
    spinner: threading.Thread | None = None
    code = 0
    with stop_on_signals(interrupt=run is not None) as stop:
        try:
            nodes = build()
            check_configuration(nodes, argv)
            for node in nodes:
                executor.add_node(node)
            if run is None:
                spin_until(executor, stop)
            else:
                spinner = threading.Thread(target=spin_until, args=(executor, stop))
                spinner.start()
                run(nodes)
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        except (ValueError, ParameterException) as err:
            rclpy.logging.get_logger(name).error(f'cannot start: {err}')
            code = 2
        finally:
            stop.set()
            if spinner is not None:
                # The spinning thread must end before its nodes and the context go away.
                spinner.join()
            # The order of rclpy.spin: detach the nodes from the executor before destroying them.
            for node in nodes:
                executor.remove_node(node)
                node.destroy_node()
            executor.shutdown()
            shutdown()
    return code


@contextmanager
def described(build: Callable[[], list[Node]], argv: list[str]) -> Iterator[list[Node]]:
    """The nodes ``build`` makes with the ROS arguments ``argv``, built to be described, never run:
    no discovery, their algorithms' state not built (:attr:`ImageStage.describing`), their log
    silenced; destroyed on exit.

    Raises:
        ValueError, ParameterException: A value the nodes refuse.
    """
    with quiet_discovery():
        nodes: list[Node] = []
        try:
            # The nodes are built, not run: what they log while being built is not the answer.
            init_without_signal_handlers([*argv, '--ros-args', '--log-level', 'fatal'])
            ImageStage.describing = True
            nodes = build()
            for node in nodes:
                declare_strict(node)
            yield nodes
        finally:
            for node in nodes:
                node.destroy_node()
            ImageStage.describing = False
            shutdown()


def _print_usage(build: Callable[[], list[Node]], argv: list[str], name: str, summary: str) -> int:
    try:
        with described(build, argv) as nodes:
            print(usage(name, nodes, summary))
    except (ValueError, ParameterException) as err:
        print(f'{name}: cannot start: {err}', file=sys.stderr)
        return 2
    return 0


def spin_node(factory: Callable[[], Node], args: list[str] | None, *, name: str, summary: str = '') -> int:
    """Spin the one node ``factory`` makes; ``name`` is the executable's (see :func:`run_nodes`)."""
    return run_nodes(lambda: [factory()], args, name=name, summary=summary)
