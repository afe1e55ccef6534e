"""The package's thread policy: how many threads numba's and OpenCV's parallel loops use.

A robot's computer is busy: with their default pools (one thread per core) the parallel
loops wait for cores that other processes hold, and the frame rate swings. One thread per
process by default keeps it steady; ``HUMAN_TRACKER_THREADS`` (or a node's ``threads``
parameter, or ``track --threads``) chooses another count, 0 meaning every core.
"""

from __future__ import annotations

import os

import cv2
import numba

__all__ = ['DEFAULT_THREADS', 'ENVIRONMENT_VARIABLE', 'default_threads', 'use_threads']

ENVIRONMENT_VARIABLE = 'HUMAN_TRACKER_THREADS'
DEFAULT_THREADS = 1


def default_threads() -> int:
    """The thread count from ``HUMAN_TRACKER_THREADS``, or :data:`DEFAULT_THREADS`.

    Raises:
        ValueError: The variable is not a whole number >= 0.
    """
    text = os.environ.get(ENVIRONMENT_VARIABLE, '').strip()
    if not text:
        return DEFAULT_THREADS
    if not text.isdigit():
        raise ValueError(f'{ENVIRONMENT_VARIABLE} must be a whole number >= 0 (0: every core), got {text!r}')
    return int(text)


def use_threads(count: int) -> int:
    """Run numba's and OpenCV's parallel loops on ``count`` threads (0: every core); return the count used.

    numba's setting belongs to the calling thread: call this from the thread that processes
    the frames.
    """
    if count < 0:
        raise ValueError(f'threads must be >= 0 (0: every core), got {count}')
    available = numba.config.NUMBA_NUM_THREADS
    used = available if count == 0 else min(count, available)
    numba.set_num_threads(used)
    cv2.setNumThreads(used)
    return used
