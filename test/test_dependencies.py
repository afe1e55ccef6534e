"""What a robot installs: package.xml's rosdep keys and the README's pip line together cover
every runtime requirement, at the versions pinned here."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from conftest import REPO

# requirements.txt names that a rosdep key of package.xml provides on a Jazzy robot.
ROSDEP_PROVIDES = {
    'numpy': 'python3-numpy',
    'scipy': 'python3-scipy',
    'opencv-python-headless': 'python3-opencv',
    'PyYAML': 'python3-yaml',
    'matplotlib': 'python3-matplotlib',
    'pandas': 'python3-pandas',
}


def _requirements() -> dict[str, str]:
    pins = {}
    for line in (REPO / 'requirements.txt').read_text().splitlines():
        line = line.split('#')[0].strip()
        if line:
            name, version = line.split('==')
            pins[re.sub(r'\[.*\]', '', name)] = version
    return pins


def test_the_robot_gets_every_runtime_requirement_the_virtualenv_has() -> None:
    keys = {e.text for e in ET.parse(REPO / 'package.xml').getroot().iter('exec_depend')}
    readme = (REPO / 'README.md').read_text()
    pip_line = next(line for line in readme.splitlines() if line.strip().startswith('pip install'))
    pinned = dict(re.findall(r'([\w-]+)==([\w.]+)', pip_line))
    for name, version in _requirements().items():
        if name.startswith('ros-jazzy-'):
            assert name.removeprefix('ros-jazzy-').replace('-', '_') in keys, name
        elif name in ROSDEP_PROVIDES:
            assert ROSDEP_PROVIDES[name] in keys, name
        else:
            # dlib among them: the head's face detector must not be silently missing on a robot.
            assert pinned.get(name) == version, f'{name}=={version} is not on the README pip line: {pip_line}'


def test_a_head_tracker_without_its_face_detector_says_so(monkeypatch) -> None:
    """Without dlib a head tracker is another tracker (no face proposals): it says so in the
    warnings /diagnostics and status carry, instead of quietly running without."""
    import rclpy

    import human_tracker.vision.faces.schedule as face_schedule

    monkeypatch.setattr(face_schedule, 'face_detector_available', lambda: False)
    from human_tracker.ros.tracker_node import TrackerNode

    rclpy.init()
    try:
        node = TrackerNode()
        warnings = node.warnings()
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    assert any('proposals: faces needs dlib' in w for w in warnings), warnings
