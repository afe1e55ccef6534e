"""The ament_python package builds with colcon and every executable starts from the install space."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import REPO
from ros_harness import environment

EXECUTABLES = (
    'tracker_node',
    'pipeline',
    'background_node',
    'optical_flow_node',
    'skin_node',
    'video_publisher',
    'bag_play',
    'human_tracker',
)
IGNORE = shutil.ignore_patterns(
    '.git', '.venv*', 'out', 'build', 'install', 'log', '__pycache__', '.*_cache', '*.egg-info'
)


@pytest.fixture(scope='module')
def install_space(tmp_path_factory) -> Path:
    colcon = Path(sys.executable).with_name('colcon')
    workspace = tmp_path_factory.mktemp('workspace')
    shutil.copytree(REPO, workspace / 'src' / 'human_tracker', ignore=IGNORE)
    result = subprocess.run(
        [
            str(colcon),
            'build',
            '--base-paths',
            'src',
            '--build-base',
            'build',
            '--install-base',
            'install',
            '--event-handlers',
            'console_direct+',
        ],
        cwd=workspace,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return workspace / 'install'


def _sourced(install: Path, command: str, **kwargs) -> subprocess.Popen:
    """Run ``command`` in bash after ``source install/setup.bash``, as a ROS user does."""
    script = f'source {install}/setup.bash && exec {command}'
    return subprocess.Popen(
        ['bash', '-c', script],
        cwd=install.parent,  # not the checkout: python -c puts the working directory first on sys.path
        env=environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        **kwargs,
    )


def test_share_files_and_scripts_are_installed(install_space: Path) -> None:
    # One package: the interfaces/ copies (COLCON_IGNORE) are not built over a robot's own.
    assert sorted(p.name for p in install_space.iterdir() if p.is_dir()) == ['human_tracker']
    share = install_space / 'human_tracker' / 'share'
    assert (share / 'ament_index' / 'resource_index' / 'packages' / 'human_tracker').exists()
    for name in (
        'package.xml',
        'launch/human_tracker.launch.py',
        'config/human_tracker.yaml',
        'config/hand_tracker.yaml',
        'config/fastdds_large_shm.xml',
        'config/human_tracker.rviz',
    ):
        assert (share / 'human_tracker' / name).exists(), name
    for name in EXECUTABLES:
        assert (install_space / 'human_tracker' / 'lib' / 'human_tracker' / name).exists(), name


def test_sourced_install_space_imports_the_installed_package(install_space: Path) -> None:
    process = _sourced(install_space, f'{sys.executable} -c "import human_tracker; print(human_tracker.__file__)"')
    out, _ = process.communicate(timeout=60)
    assert process.returncode == 0, out
    assert out.strip().startswith(str(install_space)), out


@pytest.mark.parametrize('name', ['bag_play', 'human_tracker'])
def test_command_line_tools_start(install_space: Path, name: str) -> None:
    process = _sourced(install_space, f'{install_space}/human_tracker/lib/human_tracker/{name} --help')
    out, _ = process.communicate(timeout=60)
    assert process.returncode == 0 and 'usage' in out, out


@pytest.mark.parametrize('name', ['tracker_node', 'pipeline', 'background_node', 'optical_flow_node', 'skin_node'])
def test_nodes_start_and_stop_cleanly(install_space: Path, name: str, tmp_path: Path) -> None:
    log = (tmp_path / 'node.log').open('w+')
    script = f'source {install_space}/setup.bash && exec {install_space}/human_tracker/lib/human_tracker/{name}'
    process = subprocess.Popen(
        ['bash', '-c', script], cwd=install_space.parent, env=environment(), stdout=log, stderr=subprocess.STDOUT
    )
    deadline = time.monotonic() + 60
    while 'ready' not in (tmp_path / 'node.log').read_text() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    output = (tmp_path / 'node.log').read_text()
    assert 'ready' in output, output
    process.send_signal(signal.SIGINT)
    assert process.wait(20) == 0, (tmp_path / 'node.log').read_text()


def test_every_executable_runs_by_name_from_the_virtualenv(tmp_path: Path) -> None:
    """``make venv`` installs the checkout: each executable of setup.py is in the virtualenv's
    bin, and a node started there takes ``--ros-args`` as ``ros2 run`` would give them."""
    bin_folder = Path(sys.executable).parent
    for name in EXECUTABLES:
        assert (bin_folder / name).exists(), f'{name} is not in {bin_folder}: run `make venv`'
    log = (tmp_path / 'node.log').open('w+')
    command = [str(bin_folder / 'pipeline'), '--ros-args', '-p', 'motion_cue:=background', '-p', 'target:=hand']
    process = subprocess.Popen(command, cwd=tmp_path, env=environment(), stdout=log, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 60
    while 'ready' not in (tmp_path / 'node.log').read_text() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    output = (tmp_path / 'node.log').read_text()
    assert 'ready' in output and 'hand' in output, output
    process.send_signal(signal.SIGINT)
    assert process.wait(20) == 0, (tmp_path / 'node.log').read_text()
