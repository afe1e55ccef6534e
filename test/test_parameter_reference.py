"""Each parameter declared once: the shipped YAML and docs/parameters.md are made from the nodes'
declarations and must be current; every constant of an algorithm is a declared field."""

from __future__ import annotations

from dataclasses import fields

import pytest
import yaml

from human_tracker.ros import parameter_reference as reference
from human_tracker.vision.cues.background import BackgroundParameters
from human_tracker.vision.cues.optical_flow import FlowParameters
from human_tracker.vision.cues.skin import SkinParameters
from human_tracker.vision.filter.parameters import TrackerParameters
from human_tracker.vision.track.parameters import TargetParameters


@pytest.fixture(scope='module')
def declared() -> dict[str, list[reference.Declaration]]:
    return reference.declarations()


def test_the_shipped_yaml_is_made_from_the_declarations(declared) -> None:
    assert reference.YAML_PATH.read_text() == reference.parameters_yaml(declared), (
        'config/human_tracker.yaml is out of date: python -m human_tracker.ros.parameter_reference'
    )


def test_the_docs_tables_are_made_from_the_declarations(declared) -> None:
    assert reference.markdown_tables(declared) in reference.DOCS_PATH.read_text(), (
        'docs/parameters.md is out of date: python -m human_tracker.ros.parameter_reference'
    )


def test_the_yaml_sets_every_default_but_those_the_target_or_the_environment_decides(declared) -> None:
    sections = yaml.safe_load(reference.YAML_PATH.read_text())
    for node, rows in declared.items():
        values = sections[node]['ros__parameters']
        assert values == {row.name: row.default for row in rows if not row.decided_at_start}
    tracker = {row.name: row for row in declared['tracker_node']}
    assert tracker['init_region'].hand_default == 'skin' and tracker['init_region'].default == 'motion'
    assert 'init_region' not in sections['tracker_node']['ros__parameters']
    assert tracker['threads'].from_environment and tracker['target'].hand_default is None


@pytest.mark.parametrize(
    'parameters', [TrackerParameters, TargetParameters, BackgroundParameters, FlowParameters, SkinParameters]
)
def test_every_constant_of_an_algorithm_is_declared_with_its_meaning(parameters) -> None:
    undeclared = [f.name for f in fields(parameters) if 'declared' not in f.metadata]
    assert undeclared == []
    for f in fields(parameters):
        meaning = f.metadata['declared']
        assert meaning.description.strip()
        if meaning.low is not None:
            assert meaning.low <= f.default <= meaning.high, f.name
