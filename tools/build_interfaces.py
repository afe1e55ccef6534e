"""Build the interface packages of ``interfaces/`` (tf2_msgs, hri_msgs, vision_msgs) into a
virtualenv with the rosidl tool chain from PyPI (``requirements-interfaces.txt``).

Run it with the virtualenv's own Python: ``.venv/bin/python tools/build_interfaces.py``. The
packages are installed into the virtualenv's prefix, beside the ROS wheels' own messages, so
``import tf2_msgs.msg`` works there without any other setting. On a robot none of this runs:
apt's packages are the real ones (``package.xml`` declares them).

The ROS message wheels were built elsewhere and their exported CMake files name that machine's
Python and numpy include folders; they are rewritten to this virtualenv's own once, before the
build (``notes/ros-interfaces-from-pip.md``).

``--copy-from OTHER_VENV`` installs what this tool built into another virtualenv of the same
Python and ROS wheels instead of building again: the robot-stack virtualenv takes ``.venv``'s. The
generated extensions are compiled against numpy 2's headers, which numpy 1.26 loads too.
"""

from __future__ import annotations

import argparse
import os
import shutil
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


def installed_prefix(work: Path) -> Path:
    """The install prefix a configured build folder was made for."""
    for line in (work / 'CMakeCache.txt').read_text().splitlines():
        if line.startswith('CMAKE_INSTALL_PREFIX:'):
            return Path(line.split('=', 1)[1])
    raise ValueError(f'{work}: no CMAKE_INSTALL_PREFIX')


def copy_install(work: Path, prefix: Path) -> None:
    """Copy the files a finished build in ``work`` installed into another prefix to ``prefix``,
    with that prefix's path rewritten in the text files that name it (setup scripts, CMake
    exports). Raises ``FileNotFoundError`` when the build or one of its files is missing."""
    old = installed_prefix(work)
    sources = [Path(line) for line in (work / 'install_manifest.txt').read_text().splitlines() if line]
    if missing := [source for source in sources if not source.is_file()]:
        raise FileNotFoundError(f'{missing[0]} (and {len(missing) - 1} more) of {work} are gone')
    for source in sources:
        target = prefix / source.relative_to(old)
        target.parent.mkdir(parents=True, exist_ok=True)
        data = source.read_bytes()
        if bytes(old) in data and not data.startswith(b'\x7fELF'):
            data = data.replace(bytes(old), bytes(prefix))
        target.write_bytes(data)
        shutil.copymode(source, target)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--source', type=Path, default=Path(__file__).resolve().parents[1] / 'interfaces')
    parser.add_argument('--work', type=Path, default=Path('build/interfaces'), help='build folder (%(default)s)')
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1)
    parser.add_argument(
        '--copy-from', type=Path, metavar='VENV', help='install the build made for this virtualenv instead of building'
    )
    arguments = parser.parse_args(argv)
    prefix = Path(sys.prefix)
    if prefix == Path(sys.base_prefix):
        parser.error("run this with a virtualenv's Python: it installs into that virtualenv")
    if arguments.copy_from is not None:
        for package in PACKAGES:
            copy_install(arguments.work.resolve() / arguments.copy_from.name / package, prefix)
            print(f'installed {package} into {prefix} from the build for {arguments.copy_from}')
        return 0
    localise_cmake_exports(prefix)
    for package in PACKAGES:
        work = arguments.work.resolve() / prefix.name / package
        build(arguments.source / package, work, prefix, arguments.jobs)
        print(f'built {package} into {prefix}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
