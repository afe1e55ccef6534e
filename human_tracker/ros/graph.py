"""A look at the ROS graph where ros2cli is not installed (a virtualenv): ``human_tracker topics``,
``human_tracker echo TOPIC`` and ``human_tracker call SERVICE``.

On a robot, ``ros2 topic list -t``, ``ros2 topic hz``, ``ros2 topic echo`` and ``ros2 service
call`` do the same. These run in the current ``ROS_DOMAIN_ID``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sized
from contextlib import contextmanager

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from std_srvs.srv import Trigger

from human_tracker.ros.bag_play import message_class

__all__ = ['call', 'echo', 'message_text', 'topics']

# The most seconds a new participant waits for the graph's discovery to settle before it looks.
DISCOVERY_WAIT = 10.0


# Longer arrays (image pixels, covariances of many particles) are shown by their length only.
LONGEST_SHOWN = 36


def message_text(msg: object, indent: str = '') -> str:
    """A message as indented ``field: value`` lines, as ``ros2 topic echo`` shows it; arrays longer
    than :data:`LONGEST_SHOWN` by their length."""
    lines = []
    for field in msg.get_fields_and_field_types():  # type: ignore[attr-defined]
        value = getattr(msg, field)
        if isinstance(value, bytes) and len(value) == 1:  # a byte field (a diagnostic's level)
            value = value[0]
        if hasattr(value, 'get_fields_and_field_types'):
            lines += [f'{indent}{field}:', message_text(value, indent + '  ')]
        elif isinstance(value, Sized) and not isinstance(value, str):
            items = list(value) if len(value) <= LONGEST_SHOWN else None
            if items is None:
                lines.append(f'{indent}{field}: <{len(value)} values>')
            elif items and hasattr(items[0], 'get_fields_and_field_types'):
                lines.append(f'{indent}{field}:')
                lines += [f'{indent}- ' + message_text(item, indent + '  ').lstrip() for item in items]
            else:
                lines.append(f'{indent}{field}: {[v.item() if hasattr(v, "item") else v for v in items]}')
        else:
            lines.append(f'{indent}{field}: {value!r}')
    return '\n'.join(lines)


@contextmanager
def _graph_node() -> Iterator[tuple[Node, SingleThreadedExecutor]]:
    context = Context()
    rclpy.init(context=context)
    node = Node('human_tracker_graph', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        # Discovery takes its time on a busy machine: look once another node is known and the
        # graph has stopped changing for a second.
        deadline, seen, steady = time.monotonic() + DISCOVERY_WAIT, None, 0
        while time.monotonic() < deadline and steady < 4:
            _spin_for(executor, 0.25)
            now = (sorted(node.get_node_names_and_namespaces()), sorted(node.get_topic_names_and_types()))
            others = len(now[0]) > 1
            steady, seen = (steady + 1 if others and now == seen else 0), now
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()


def _spin_for(executor: SingleThreadedExecutor, seconds: float, done: Callable[[], bool] = lambda: False) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not done():
        executor.spin_once(timeout_sec=0.05)


def topics(seconds: float = 2.0) -> list[str]:
    """One line per topic of the graph: its name, type, publishers and subscribers, and the rate
    its messages arrived at over ``seconds`` (Hz). A topic discovered during those seconds (a
    busy machine's discovery comes in pieces) is listed too, its rate measured from then."""
    lines = []
    with _graph_node() as (node, executor):
        counts: dict[str, int] = {}
        since: dict[str, float] = {}

        def watch_new_topics() -> None:
            for name, types in node.get_topic_names_and_types():
                if name in since or name in ('/rosout', '/parameter_events'):
                    continue
                since[name] = time.monotonic()
                try:
                    kind = message_class(types[0])
                except ValueError:
                    continue
                counts[name] = 0
                node.create_subscription(
                    kind,
                    name,
                    lambda _, n=name: counts.__setitem__(n, counts[n] + 1),
                    qos_profile_sensor_data,
                    raw=True,
                )

        end = time.monotonic() + seconds
        while time.monotonic() < end:
            watch_new_topics()
            _spin_for(executor, min(0.25, max(0.0, end - time.monotonic())))
        for name, types in sorted(node.get_topic_names_and_types()):
            if name not in counts:
                continue
            publishers, subscribers = node.count_publishers(name), node.count_subscribers(name) - 1
            rate = counts[name] / max(end - since[name], 0.25)
            lines.append(
                f'{name} [{", ".join(types)}] {publishers} publishers, {subscribers} subscribers, {rate:.1f} Hz'
            )
    return lines


def echo(topic: str, count: int = 1, timeout: float = 10.0) -> list[str]:
    """The first ``count`` messages on ``topic`` (its type found on the graph) as YAML, within
    ``timeout`` s of the topic being discovered.

    Raises:
        ValueError: No such topic on the graph within ``timeout`` s.
    """
    with _graph_node() as (node, executor):
        # A stale participant of the same domain can make the graph look settled before the
        # topic's publisher is discovered: wait for the topic, as ``ros2 topic echo`` does.
        deadline = time.monotonic() + timeout
        while not (types := dict(node.get_topic_names_and_types()).get(topic)) and time.monotonic() < deadline:
            _spin_for(executor, 0.25)
        if not types:
            known = ', '.join(sorted(name for name, _ in node.get_topic_names_and_types())) or 'none'
            raise ValueError(f'no topic {topic} on the graph; topics: {known}')
        received: list[str] = []
        node.create_subscription(
            message_class(types[0]), topic, lambda msg: received.append(message_text(msg)), qos_profile_sensor_data
        )
        _spin_for(executor, timeout, lambda: len(received) >= count)
    return received[:count]


def call(service: str, timeout: float = 10.0) -> str:
    """Call a std_srvs/Trigger service (a node's ``~/reset``, ``bag_play``'s ``~/pause``); its answer.

    Raises:
        ValueError: The service did not answer within ``timeout`` s.
    """
    with _graph_node() as (node, executor):
        client = node.create_client(Trigger, service)
        if not client.wait_for_service(timeout_sec=timeout):
            raise ValueError(f'no std_srvs/Trigger service {service} on the graph')
        future = client.call_async(Trigger.Request())
        _spin_for(executor, timeout, future.done)
        if not future.done():
            raise ValueError(f'{service} did not answer within {timeout} s')
        answer = future.result()
    return f'success: {answer.success}, message: {answer.message!r}'
