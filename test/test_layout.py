"""The method's layout: ``vision/``'s sub-packages in layers, each importing only those below it,
no import circle among its modules, each sub-package's public names importable, and no ROS."""

from __future__ import annotations

import ast
import importlib
from graphlib import CycleError, TopologicalSorter

import pytest
from conftest import REPO

VISION = REPO / 'human_tracker' / 'vision'
# Bottom to top: a module may import its own layer and those before it.
LAYERS = ('checks', 'filter', 'geometry', 'cues', 'faces', 'track', 'people', 'frame_pipeline')
ROS = ('rclpy', 'sensor_msgs', 'geometry_msgs', 'std_msgs', 'rosbags', 'diagnostic_msgs')


def _module(path) -> str:
    parts = path.relative_to(REPO).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def _imports() -> dict[str, set[str]]:
    """Every vision module's imports (those under ``if TYPE_CHECKING`` too), by module name."""
    found = {}
    for path in VISION.rglob('*.py'):
        names = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                names.add(node.module)
            elif isinstance(node, ast.Import):
                names.update(alias.name for alias in node.names)
        found[_module(path)] = names
    return found


def _layer(module: str) -> int:
    return LAYERS.index(module.split('.')[2])


@pytest.mark.parametrize('package', LAYERS[1:-1])
def test_each_sub_package_lists_its_public_names(package: str) -> None:
    module = importlib.import_module(f'human_tracker.vision.{package}')
    assert module.__doc__ and module.__all__
    for name in module.__all__:
        assert getattr(module, name) is not None


def test_no_module_imports_a_layer_above_its_own_or_ros() -> None:
    upward, ros = [], []
    for module, imports in _imports().items():
        if module == 'human_tracker.vision':
            continue
        for name in imports:
            if name.startswith('human_tracker.vision.') and _layer(name) > _layer(module):
                upward.append(f'{module} -> {name}')
            if name.split('.')[0] in ROS:
                ros.append(f'{module} -> {name}')
    assert upward == [] and ros == []


def test_no_import_circle_among_the_modules() -> None:
    modules = _imports()
    graph = {module: {name for name in imports if name in modules} for module, imports in modules.items()}
    try:
        TopologicalSorter(graph).prepare()
    except CycleError as err:
        pytest.fail(f'import circle: {" -> ".join(err.args[1])}')


def test_no_module_is_longer_than_one_reader_holds() -> None:
    """About 400 lines at most: a module does one job (a longer one is split by concern)."""
    longest = 410
    long = {
        str(path.relative_to(REPO)): lines
        for path in (REPO / 'human_tracker').rglob('*.py')
        if (lines := len(path.read_text().splitlines())) > longest
    }
    assert long == {}
