"""Shared test setup: an isolated local DDS domain per test process, and paths."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

# Set before any rclpy import so every participant of this process joins the same private
# domain; nodes started as child processes inherit it.
os.environ['ROS_DOMAIN_ID'] = str(1 + os.getpid() % 200)
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')

REPO = Path(__file__).resolve().parents[1]
HEAD_BAG = REPO / 'bags' / 'head_basic'
REAL_DATA = REPO.parent / 'shared' / 'data' / 'real'


@pytest.fixture
def head_bag() -> Path:
    """The bundled head-and-shoulders bag (JPEG frames, ground truth)."""
    assert HEAD_BAG.exists(), f'{HEAD_BAG} is missing: run `make bags`'
    return HEAD_BAG
