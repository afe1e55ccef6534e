"""Shared test setup: an isolated local DDS domain per test process, and paths."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

# Set before any rclpy import so every participant of this process joins the same private
# domain; nodes started as child processes inherit it. Under pytest-xdist (`make test` runs two
# workers) the worker's number keeps the two workers' domains apart.
_WORKER = int(os.environ.get('PYTEST_XDIST_WORKER', 'gw0').removeprefix('gw'))
os.environ['ROS_DOMAIN_ID'] = str(1 + _WORKER % 2 + 2 * (os.getpid() % 100))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')

REPO = Path(__file__).resolve().parents[1]
BAGS = REPO / 'bags'
HEAD_BAG = BAGS / 'head_basic'
REAL_DATA = REPO.parent / 'shared' / 'data' / 'real'
DLIB_MISSING = 'the face detector (dlib) is a dependency of the head tracker: pip install dlib-bin (see README)'


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        'markers',
        'timed: bounds a time (first frames late, --help CPU) that another busy process would break: '
        '`make test` runs these alone, after the rest',
    )


@pytest.fixture
def head_bag() -> Path:
    """The bundled head-and-shoulders bag (JPEG frames, ground truth)."""
    assert HEAD_BAG.exists(), f'{HEAD_BAG} is missing: run `make bags`'
    return HEAD_BAG


@pytest.fixture(autouse=True)
def _rclpy_shut_down_after_each_test() -> Iterator[None]:
    """rclpy's context is shut down after every test, even one that failed between
    ``rclpy.init()`` and its own clean-up: a context left up breaks every later ``init``."""
    yield
    rclpy = sys.modules.get('rclpy')
    if rclpy is not None and rclpy.ok():
        rclpy.try_shutdown()
