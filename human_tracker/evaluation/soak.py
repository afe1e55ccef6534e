"""Soak run: the single-process pipeline's nodes over many looped frames; memory and accounting.

The real node objects of ``pipeline`` (camera subscriber, background subtraction, tracker)
receive the frames of a bundled bag in a loop, as raw Image messages through the same entry
point a subscription uses, stamped 1/30 s apart (every loop continues the clock, so no frame
is a duplicate). The resident memory is read after a warm-up and at the end.

    python -m human_tracker.evaluation.soak --frames 100000 --out out/bench/soak.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import psutil
import rclpy

from human_tracker.io.bags import read_frames
from human_tracker.ros.common import shutdown
from human_tracker.ros.image_conversion import array_to_image, message_to_bgr8
from human_tracker.ros.pipeline import build_pipeline

__all__ = ['soak', 'main']


def soak(bag: Path, frames: int, warm_up: int = 1000) -> dict[str, object]:
    """Feed ``frames`` looped frames of ``bag`` to the pipeline's nodes; return the figures."""
    images = [array_to_image(message_to_bgr8(f.message), 'bgr8') for f in read_frames(bag)]
    process = psutil.Process()
    rclpy.init()
    nodes = build_pipeline()
    camera, tracker = nodes[1], nodes[-1]
    rss_start = 0
    started = time.monotonic()
    try:
        for index in range(frames):
            message = images[index % len(images)]
            message.header.stamp.sec, message.header.stamp.nanosec = divmod(
                1_000_000_000 + index * 33_333_333, 1_000_000_000
            )
            camera.on_image(message)
            if index + 1 == warm_up:
                rss_start = process.memory_info().rss
        rss_end = process.memory_info().rss
        counters = {name: node.counters.as_dict() for name, node in (('camera', camera), ('tracker', tracker))}
        status = tracker.tracker.status
    finally:
        for node in nodes:
            node.destroy_node()
        shutdown()
    elapsed = time.monotonic() - started
    return {
        'frames': frames,
        'seconds': round(elapsed, 1),
        'frames_per_second': round(frames / elapsed, 1),
        'rss_mb_after_warm_up': round(rss_start / 2**20, 1),
        'rss_mb_end': round(rss_end / 2**20, 1),
        'rss_growth_mb': round((rss_end - rss_start) / 2**20, 1),
        'counters': counters,
        'tracker_status_at_end': status,
    }


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m human_tracker.evaluation.soak``."""
    parser = argparse.ArgumentParser(description='Soak the pipeline over many looped frames.')
    parser.add_argument('--bag', type=Path, default=Path('bags/head_basic'))
    parser.add_argument('--frames', type=int, default=100_000)
    parser.add_argument('--out', type=Path, default=Path('out/bench/soak.json'))
    options = parser.parse_args(argv)
    result = soak(options.bag, options.frames)
    options.out.parent.mkdir(parents=True, exist_ok=True)
    options.out.write_text(json.dumps(result, indent=2) + '\n')
    print(json.dumps(result, indent=2))
    return 0


if __name__ == '__main__':
    sys.exit(main())
