"""The ``human_tracker`` command: offline tools around the tracker (no ROS graph needed)."""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

__all__ = ['main']


def _generate(options: argparse.Namespace) -> int:
    from human_tracker.io.bags import write_scene_bag
    from human_tracker.scenes.generator import SCENES

    names = sorted(SCENES) if options.all else options.scene
    unknown = [name for name in names if name not in SCENES]
    if unknown or not names:
        print(
            f'human_tracker generate: unknown or no scene {unknown}; known: {", ".join(sorted(SCENES))}',
            file=sys.stderr,
        )
        return 2
    for name in names:
        path = options.out / name
        if path.exists():
            shutil.rmtree(path)
        write_scene_bag(SCENES[name], path, compressed=not options.raw, storage=options.storage)
        print(f'wrote {path}')
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``human_tracker``; returns the exit code."""
    parser = argparse.ArgumentParser(
        prog='human_tracker', description='Head and hand silhouette tracking, offline tools.'
    )
    commands = parser.add_subparsers(dest='command', required=True)
    generate = commands.add_parser('generate', help='render seeded synthetic scenes into rosbag2 bags')
    generate.add_argument('scene', nargs='*', default=[], help='scene names (see --all)')
    generate.add_argument('--all', action='store_true', help='every bundled scene')
    generate.add_argument('--out', type=Path, default=Path('bags'), help='folder for the bags (default bags/)')
    generate.add_argument('--raw', action='store_true', help='raw bgr8 Image instead of JPEG CompressedImage')
    generate.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap')
    generate.set_defaults(run=_generate)
    options = parser.parse_args(argv)
    return int(options.run(options))


if __name__ == '__main__':
    sys.exit(main())
