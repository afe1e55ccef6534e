"""A node's process keeps freed frame-sized memory for the next frame (glibc)."""

from __future__ import annotations

import subprocess
import sys

import pytest

_FRAMES = """
import resource
import numpy as np
from human_tracker.ros.memory import keep_freed_memory
if {keep}:
    assert keep_freed_memory()
def frame():
    # Four buffers of a 640x480 colour frame, freed together: a frame's message and arrays.
    return [np.ones(640 * 480 * 3, np.uint8) for _ in range(4)]
frame()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(50):
    frame()
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _page_faults(keep: bool) -> int:
    run = subprocess.run([sys.executable, '-c', _FRAMES.format(keep=keep)], capture_output=True, text=True, check=True)
    return int(run.stdout)


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='glibc malloc settings')
def test_frame_buffers_are_not_faulted_in_again_on_every_frame() -> None:
    # 50 frames of 4 x 900 KB: about 45 000 page faults when each frame's memory goes back
    # to the system, none when it is kept.
    assert _page_faults(keep=False) > 50 * 225
    assert _page_faults(keep=True) < 50
