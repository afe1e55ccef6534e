"""Run the package's nodes as separate OS processes on an isolated, local DDS domain.

Used by the demo and the tests; a robot uses ``ros2 launch`` instead.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType

__all__ = ['FASTDDS_PROFILE', 'READY_NODES', 'ros_environment', 'use_ros_environment', 'NodeProcess']

FASTDDS_PROFILE = Path(__file__).resolve().parents[2] / 'config' / 'fastdds_large_shm.xml'

# The node of each executable whose ``ready`` says the executable can take frames (the
# pipeline's camera subscriber warms every stage up before it says so).
READY_NODES = {
    'human_tracker.ros.background_node': '/background_node',
    'human_tracker.ros.optical_flow_node': '/optical_flow_node',
    'human_tracker.ros.skin_node': '/skin_node',
    'human_tracker.ros.tracker_node': '/tracker_node',
    'human_tracker.ros.pipeline': '/camera_subscriber',
}


def ros_environment(domain_id: int, base: dict[str, str] | None = None) -> dict[str, str]:
    """Environment for nodes on ``domain_id``, discovering only on this machine.

    The Fast DDS profile with a 16 MB shared-memory segment is used when it is found in the
    checkout and no other profile was set.
    """
    env = dict(os.environ if base is None else base)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
    if FASTDDS_PROFILE.exists():
        env.setdefault('FASTRTPS_DEFAULT_PROFILES_FILE', str(FASTDDS_PROFILE))
    env['PYTHONUNBUFFERED'] = '1'
    return env


def use_ros_environment(domain_id: int) -> dict[str, str]:
    """Put this process on ``domain_id`` as :func:`ros_environment` does (before rclpy.init);
    return that environment for its child processes."""
    env = ros_environment(domain_id)
    os.environ.update({k: v for k, v in env.items() if k.startswith(('ROS_', 'RMW_', 'FASTRTPS_'))})
    return env


class NodeProcess:
    """A ``python -m module args`` child process, stopped with SIGINT like Ctrl-C.

    Its output goes to ``log_path`` so a failing test or demo can show it.
    """

    def __init__(self, module: str, args: Sequence[str], env: dict[str, str], log_path: Path) -> None:
        self.command = [sys.executable, '-m', module, *args]
        self.ready_node = READY_NODES.get(module)
        self.env = env
        self.log_path = log_path
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> NodeProcess:
        """Start the process; a second start while it runs is refused (the first would run on,
        unstopped, on the same ROS domain)."""
        if self.process is not None and self.process.poll() is None:
            raise RuntimeError(f'{self.command[2]} is already running (pid {self.process.pid})')
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        log = self.log_path.open('wb')
        self.process = subprocess.Popen(self.command, env=self.env, stdout=log, stderr=subprocess.STDOUT)
        log.close()
        return self

    def wait(self, timeout: float) -> int:
        """Wait for the process to exit by itself; returns its exit code."""
        assert self.process is not None
        return self.process.wait(timeout)

    def stop(self, timeout: float = 10.0) -> int:
        """Interrupt the process (SIGINT), kill it if it does not exit; returns the exit code."""
        assert self.process is not None
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                return self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                self.process.kill()
        return self.process.wait()

    def output(self) -> str:
        """What the process printed so far."""
        return self.log_path.read_text(errors='replace') if self.log_path.exists() else ''

    def __enter__(self) -> NodeProcess:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None) -> None:
        self.stop()
