"""``bag_play``: replay a rosbag2 bag (sqlite3 or mcap) like ``ros2 bag play``.

Messages are published as the bag's raw serialized bytes (no deserialisation), at the
recorded rate scaled by ``--rate``, optionally looping, filtered with ``--topics`` and
renamed with ``--remap old:=new``. The publishers offer the QoS recorded in the bag's
metadata where there is one (reliable, keep last 100 otherwise). Like ``ros2 bag play``,
the services ``~/pause``, ``~/resume`` and ``~/toggle_paused`` (std_srvs/Trigger) control
playback, and ``--start-paused`` waits for ``~/resume``. ``--wait-for-ready NODE ...`` holds
the first message until each of those nodes has said it is ready (``NODE/ready``, latched:
compiled, subscribed and spinning), so a replay loses nothing to a node still starting.
``/diagnostics`` says what the player is doing and how many messages it published.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from rosbags.highlevel import AnyReaderError
from rosbags.interfaces import QosDurability, QosReliability
from rosbags.rosbag2 import ReaderError
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from human_tracker.io.bags import BagError, CutMcapReader, guarded, open_bag
from human_tracker.ros.common import (
    LATCHED_QOS,
    RESULT_QOS,
    init_without_signal_handlers,
    node_status,
    publish_diagnostics,
    shutdown,
    spin_until,
    stop_on_signals,
)
from human_tracker.ros.startup import StartError, check_configuration, without_help

__all__ = ['BagPlayer', 'main', 'message_class']

_PAUSE_POLL = 0.01  # seconds between looks at the pause while a message waits for its time

_DEFAULT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)


def message_class(msgtype: str) -> type:
    """The rclpy message class of a type name like ``sensor_msgs/msg/Image``."""
    package, kind, name = msgtype.split('/')
    try:
        return getattr(importlib.import_module(f'{package}.{kind}'), name)
    except (ImportError, AttributeError) as err:
        raise ValueError(f'message type {msgtype} is not available in this ROS installation') from err


def _recorded_qos(connection: object) -> QoSProfile:
    """The first offered QoS profile recorded for a topic, or the default."""
    profiles = getattr(getattr(connection, 'ext', None), 'offered_qos_profiles', None)
    if not profiles:
        return _DEFAULT_QOS
    recorded = profiles[0]
    best_effort = recorded.reliability == QosReliability.BEST_EFFORT
    latched = recorded.durability == QosDurability.TRANSIENT_LOCAL
    reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
    durability = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
    return QoSProfile(
        depth=max(int(recorded.depth), 100),
        history=HistoryPolicy.KEEP_LAST,
        reliability=reliability,
        durability=durability,
    )


def _parse_remaps(remaps: Sequence[str]) -> dict[str, str]:
    table = {}
    for remap in remaps:
        old, sep, new = remap.partition(':=')
        if not sep or not old or not new:
            raise ValueError(f'--remap takes old:=new, got {remap!r}')
        table[old] = new
    return table


class BagPlayer(Node):
    """Publishes the messages of one bag in recorded order and timing."""

    def __init__(
        self,
        bag: Path,
        *,
        rate: float = 1.0,
        topics: Sequence[str] = (),
        remaps: dict[str, str] | None = None,
        clock: bool = False,
    ) -> None:
        super().__init__('bag_play')
        if rate <= 0:
            raise ValueError(f'--rate must be > 0, got {rate}')
        self.bag = bag
        self.rate = rate
        self.reader = open_bag(bag)
        self.reader.open()
        if isinstance(self.reader, CutMcapReader):
            self.get_logger().warn(self.reader.note)
        remaps = remaps or {}
        self.connections = [c for c in self.reader.connections if not topics or c.topic in topics]
        recorded = sorted({c.topic for c in self.reader.connections})
        # A topic named that the bag lacks (a misspelt remap, the wrong bag) is refused, not ignored.
        for option, named in (('--topics', set(topics)), ('--remap', set(remaps))):
            missing = named - set(recorded)
            if missing:
                raise ValueError(
                    f'{option}: {", ".join(sorted(missing))} not in {bag}; its topics: {", ".join(recorded)}'
                )
        self.publishers_by_id = {}
        for conn in self.connections:
            name = remaps.get(conn.topic, conn.topic)
            self.publishers_by_id[conn.id] = self.create_publisher(
                message_class(conn.msgtype), name, _recorded_qos(conn)
            )
        self.clock_pub = self.create_publisher(Clock, '/clock', 10) if clock else None
        self.published = 0
        self.state = 'STARTING'
        self.ready_nodes: set[str] = set()
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', RESULT_QOS)
        self.create_timer(1.0, self._publish_diagnostics)
        self.playing = threading.Event()
        self.playing.set()
        self.create_service(Trigger, '~/pause', lambda _, response: self._set_paused(True, response))
        self.create_service(Trigger, '~/resume', lambda _, response: self._set_paused(False, response))
        self.create_service(
            Trigger, '~/toggle_paused', lambda _, response: self._set_paused(self.playing.is_set(), response)
        )

    def _set_paused(self, paused: bool, response: Trigger.Response) -> Trigger.Response:
        if paused:
            self.playing.clear()
        else:
            self.playing.set()
        response.success = True
        response.message = 'paused' if paused else 'playing'
        self.get_logger().info(response.message)
        return response

    def _publish_diagnostics(self) -> None:
        state = 'PAUSED' if self.state == 'PLAYING' and not self.playing.is_set() else self.state
        values = {'bag': self.bag, 'messages_published': self.published, 'rate': self.rate}
        publish_diagnostics(self, self.diagnostics_pub, [node_status(self, state, values, hardware_id='bag')])

    def wait_for_ready(self, nodes: Sequence[str], timeout: float) -> list[str]:
        """Block until every node in ``nodes`` (fully qualified names) published True on its ``ready``.

        The executor must spin in another thread. Returns the nodes that did not within
        ``timeout`` seconds.
        """
        self.state = 'WAITING_FOR_NODES'
        for node in nodes:
            topic = node.rstrip('/') + '/ready'

            def on_ready(msg: Bool, node: str = node) -> None:
                if msg.data:
                    self.ready_nodes.add(node)

            self.create_subscription(Bool, topic, on_ready, LATCHED_QOS)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not set(nodes) <= self.ready_nodes:
            time.sleep(0.05)
        return sorted(set(nodes) - self.ready_nodes)

    def wait_for_subscribers(self, topic: str, count: int, timeout: float) -> bool:
        """Block until ``topic`` has ``count`` matched subscribers (or ``timeout`` seconds)."""
        publishers = [pub for pub in self.publishers_by_id.values() if pub.topic_name.lstrip('/') == topic.lstrip('/')]
        if not publishers:
            raise ValueError(f'--wait-for-subscribers: no published topic named {topic}')
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if publishers[0].get_subscription_count() >= count:
                return True
            time.sleep(0.05)
        return False

    def play_once(self, start_offset: float = 0.0) -> None:
        """Publish every selected message once, paced by the recorded timestamps.

        Time spent paused is added to the schedule, so playback resumes where it stopped.
        """
        self.state = 'PLAYING'
        start_ns = self.reader.start_time + int(start_offset * 1e9)
        wall_start = time.monotonic()
        for conn, timestamp, raw in guarded(
            self.reader.messages(connections=self.connections, start=start_ns), self.bag
        ):
            # Waited for in short steps: a pause asked for while a message waits for its time
            # holds that message too.
            while True:
                if not self.playing.is_set():
                    paused_at = time.monotonic()
                    self.playing.wait()
                    wall_start += time.monotonic() - paused_at
                delay = wall_start + (timestamp - start_ns) / 1e9 / self.rate - time.monotonic()
                if delay <= 0:
                    break
                time.sleep(min(delay, _PAUSE_POLL))
            if self.clock_pub is not None:
                self.clock_pub.publish(Clock(clock=Time(nanoseconds=timestamp).to_msg()))
            self.publishers_by_id[conn.id].publish(bytes(raw))
            self.published += 1

    def finish(self, timeout: float = 5.0) -> None:
        """Wait until reliable subscribers have acknowledged what was sent, then close."""
        self.state = 'FINISHED'
        for pub in self.publishers_by_id.values():
            pub.wait_for_all_acked(Duration(seconds=timeout))
        self.reader.close()


def _arguments(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog='bag_play', description='Replay a rosbag2 bag (sqlite3 or mcap) over ROS 2.')
    parser.add_argument('bag', type=Path, help='bag folder (or its .mcap / .db3 file)')
    parser.add_argument('-r', '--rate', type=float, default=1.0, help='playback rate factor (default 1.0)')
    parser.add_argument('-l', '--loop', action='store_true', help='replay until interrupted')
    parser.add_argument('--topics', nargs='+', default=[], help='only these topics')
    parser.add_argument('--remap', '-m', nargs='+', default=[], metavar='OLD:=NEW', help='rename topics')
    parser.add_argument('--clock', action='store_true', help='publish /clock from the bag time')
    parser.add_argument('--start-offset', type=float, default=0.0, help='seconds into the bag to start at')
    parser.add_argument('-d', '--delay', type=float, default=0.0, help='seconds to wait before playing')
    parser.add_argument(
        '-p', '--start-paused', action='store_true', help='wait for the ~/resume service before playing'
    )
    parser.add_argument(
        '--wait-for-subscribers',
        nargs=2,
        metavar=('TOPIC', 'COUNT'),
        help='wait until TOPIC has COUNT subscribers (timeout 30 s)',
    )
    parser.add_argument(
        '--wait-for-ready',
        nargs='+',
        default=[],
        metavar='NODE',
        help='wait until each node (e.g. /tracker_node) published True on NODE/ready (timeout 120 s)',
    )
    return parser.parse_args(argv)


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker bag_play BAG``; returns the exit code."""
    argv = sys.argv if args is None else args
    # Our options (``--remap old:=new`` among them) come before ``--ros-args``: rcl would
    # take ``old:=new`` for a global remap rule of this node if it saw it.
    split = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    ros_argv, wants_help = without_help([argv[0], *argv[split:]])
    options = _arguments([*argv[1:split], *(['--help'] if wants_help else [])])
    try:
        init_without_signal_handlers(ros_argv)
    except StartError as err:
        print(f'bag_play: cannot start: {err}', file=sys.stderr)
        return 2
    player = None
    executor = None
    spinner = None
    bag = options.bag
    code = 0
    with stop_on_signals(interrupt=True) as stop:
        try:
            player = BagPlayer(
                bag, rate=options.rate, topics=options.topics, remaps=_parse_remaps(options.remap), clock=options.clock
            )
            check_configuration([player], ros_argv)
            # Services (pause / resume) are served while the main thread publishes.
            executor = SingleThreadedExecutor()
            executor.add_node(player)
            spinner = threading.Thread(target=spin_until, args=(executor, stop), daemon=True)
            spinner.start()
            late = player.wait_for_ready(options.wait_for_ready, 120.0) if options.wait_for_ready else []
            if late:
                player.get_logger().warn(f'playing although {", ".join(late)} did not say ready within 120 s')
            if options.wait_for_subscribers:
                topic, count = options.wait_for_subscribers
                if not player.wait_for_subscribers(topic, int(count), 30.0):
                    player.get_logger().warn(f'playing although {topic} has fewer than {count} subscribers after 30 s')
            time.sleep(max(options.delay, 0.0))
            if options.start_paused:
                player.playing.clear()
                player.get_logger().info('paused: call ~/resume to play')
            while True:
                player.play_once(options.start_offset)
                if not options.loop:
                    break
            player.finish()
            player.get_logger().info(f'played {player.published} messages from {bag}')
        except StartError as err:
            print(f'bag_play: cannot start: {err}', file=sys.stderr)
            code = 2
        except (AnyReaderError, ReaderError, BagError, ValueError, OSError) as err:
            print(f'bag_play: error: {err}', file=sys.stderr)
            code = 1
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            stop.set()
            if spinner is not None:
                spinner.join()
            if executor is not None:
                executor.shutdown()
            if player is not None:
                player.destroy_node()
            shutdown()
    return code


if __name__ == '__main__':
    sys.exit(main())
