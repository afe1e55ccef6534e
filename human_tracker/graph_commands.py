"""The ``human_tracker topics``, ``echo`` and ``call`` commands: what ros2cli does on a robot,
from the virtualenv (:mod:`~human_tracker.ros.graph`)."""

from __future__ import annotations

import argparse

__all__ = ['add_graph_commands']


def _graph(options: argparse.Namespace) -> int:
    from human_tracker.ros import graph

    if options.command == 'topics':
        lines = graph.topics(options.seconds)
    elif options.command == 'echo':
        lines = graph.echo(options.topic, options.count, options.timeout)
        if not lines:
            raise ValueError(f'no message on {options.topic} within {options.timeout} s')
        lines = [line for text in lines for line in (text, '---')]
    else:
        lines = [graph.call(options.service, options.timeout)]
    print('\n'.join(lines))
    return 0


def add_graph_commands(commands: argparse._SubParsersAction) -> None:
    """``topics``, ``echo`` and ``call`` under ``commands``."""
    topics = commands.add_parser('topics', help="the ROS graph's topics: type, publishers, subscribers, rate")
    topics.add_argument('--seconds', type=float, default=2.0, help='how long the rates are measured (default 2)')
    topics.set_defaults(run=_graph)
    echo = commands.add_parser('echo', help="a topic's messages, as ros2 topic echo prints them")
    echo.add_argument('topic', help='topic name, e.g. /diagnostics')
    echo.add_argument('--count', type=int, default=1, help='messages to print (default 1)')
    echo.add_argument('--timeout', type=float, default=10.0, help='seconds to wait (default 10)')
    echo.set_defaults(run=_graph)
    call = commands.add_parser('call', help="call a std_srvs/Trigger service (a node's ~/reset, bag_play's ~/pause)")
    call.add_argument('service', help='service name, e.g. /tracker_node/reset')
    call.add_argument('--timeout', type=float, default=10.0, help='seconds to wait (default 10)')
    call.set_defaults(run=_graph)
