"""Build the interface packages of ``interfaces/`` (tf2_msgs, hri_msgs, vision_msgs) into a
virtualenv with the rosidl tool chain from PyPI (``requirements-interfaces.txt``).

Run it with the virtualenv's own Python: ``.venv/bin/python tools/build_interfaces.py``. The
packages are installed into the virtualenv's prefix, beside the ROS wheels' own messages, so
``import tf2_msgs.msg`` works there without any other setting. On a robot none of this runs:
apt's packages are the real ones (``package.xml`` declares them).

The ROS message wheels were built elsewhere and their exported CMake files name that machine's
Python and numpy include folders; they are rewritten to this virtualenv's own once, before the
build (``notes/ros-interfaces-from-pip.md``).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import sysconfig
from functools import partial
from pathlib import Path

import numpy as np

PACKAGES = ('tf2_msgs', 'hri_msgs', 'vision_msgs')
"""In build order: each depends only on the wheels' messages."""

FOREIGN_PYTHON = '/opt/python/cp311-cp311/include/python3.11'
FOREIGN_NUMPY = '/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include'


def localise_cmake_exports(prefix: Path) -> int:
    """Rewrite the wheels' exported include folders to this Python's and numpy's; returns how
    many files changed."""
    changed = 0
    for path in (prefix / 'share').glob('*/cmake/*.cmake'):
        text = path.read_text()
        if FOREIGN_PYTHON not in text and FOREIGN_NUMPY not in text:
            continue
        text = text.replace(FOREIGN_NUMPY, np.get_include())
        text = text.replace(FOREIGN_PYTHON, sysconfig.get_paths()['include'])
        path.write_text(text)
        changed += 1
    return changed


def build(source: Path, work: Path, prefix: Path, jobs: int) -> None:
    """Configure, build and install the interface package in ``source`` into ``prefix``."""
    environment = dict(os.environ)
    environment['PATH'] = f'{prefix / "bin"}{os.pathsep}{environment.get("PATH", "")}'
    environment['CMAKE_PREFIX_PATH'] = str(prefix)
    environment['AMENT_PREFIX_PATH'] = str(prefix)
    cmake = partial(subprocess.run, check=True, env=environment, stdout=subprocess.DEVNULL)
    tool = str(prefix / 'bin' / 'cmake')
    cmake(
        [
            tool,
            '-S', str(source),
            '-B', str(work),
            f'-DCMAKE_INSTALL_PREFIX={prefix}',
            f'-DPython3_EXECUTABLE={sys.executable}',
            '-DBUILD_TESTING=OFF',
            '-DCMAKE_BUILD_TYPE=Release',
        ]
    )  # fmt: skip
    cmake([tool, '--build', str(work), '-j', str(jobs)])
    cmake([tool, '--install', str(work)])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--source', type=Path, default=Path(__file__).resolve().parents[1] / 'interfaces')
    parser.add_argument('--work', type=Path, default=Path('build/interfaces'), help='build folder (%(default)s)')
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1)
    arguments = parser.parse_args(argv)
    prefix = Path(sys.prefix)
    if prefix == Path(sys.base_prefix):
        parser.error("run this with a virtualenv's Python: it installs into that virtualenv")
    localise_cmake_exports(prefix)
    for package in PACKAGES:
        work = arguments.work.resolve() / Path(sys.prefix).name / package
        build(arguments.source / package, work, prefix, arguments.jobs)
        print(f'built {package} into {prefix}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
