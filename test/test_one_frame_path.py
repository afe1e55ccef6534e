"""One frame path: ``track --params-file`` offline and the ``pipeline`` node over DDS, with the
same parameter files, give the same poses on every bag and on real sequences (a head, a hand,
a person); ``track`` refuses a parameter file the node refuses."""

from __future__ import annotations

import csv
import itertools
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_DATA, REPO
from ros_harness import environment, replay_and_collect

from human_tracker.cli import main
from human_tracker.demo import node_arguments
from human_tracker.io.bags import COMPRESSED_CAMERA_TOPIC, read_frames, write_bag
from human_tracker.io.sequences import open_sequence
from human_tracker.ros.processes import NodeProcess
from human_tracker.vision.filter.templates import fit_template, make_template

CONFIG = REPO / 'config' / 'human_tracker.yaml'
HAND_CONFIG = REPO / 'config' / 'hand_tracker.yaml'
# Each bag with the files and parameters a user would give both commands.
BAGS = {
    'head_basic': ([CONFIG], []),
    'head_cluttered': ([CONFIG], []),
    'head_leave_return': ([CONFIG], []),
    'head_stop_and_go': ([CONFIG], []),
    'hand_wave': ([CONFIG, HAND_CONFIG], []),
    'hand_cluttered': ([CONFIG, HAND_CONFIG], []),
    'people_crossing': ([CONFIG], ['target=person', 'max_people=2']),
}
# Real sequences: their first frames, from the first box; a head, a hand and a person.
REAL = {
    'trellis': ([CONFIG], []),
    'hand2': ([CONFIG, HAND_CONFIG], []),
    'seated_agbani': ([CONFIG], ['target=person']),
}
REAL_FRAMES = 60
POSE = ('x', 'y', 'scale', 'theta')
# What the published contour's state may differ from the offline one by: x, y px; scale px; θ rad.
TOLERANCE = np.array([0.01, 0.01, 0.01, 1e-3])


def _first_frames_as_bag(name: str, folder: Path) -> tuple[Path, tuple[float, ...]]:
    """The real sequence's first :data:`REAL_FRAMES` frames recorded as a bag (JPEG, as a camera
    driver sends them), and its first box."""
    sequence = open_sequence(REAL_DATA / name)
    frames = [(f.stamp_ns, f.image, f.ground_truth) for f in itertools.islice(sequence, REAL_FRAMES)]
    target = 'hand' if name == 'hand2' else 'head'
    return write_bag(folder / name, frames, target=target), frames[0][2]


def _offline(bag: Path, files: list[Path], overrides: list[str], out: Path) -> list[dict[str, str]]:
    arguments = ['track', str(bag), '--out', str(out), '--no-video', '--quiet']
    arguments += [a for f in files for a in ('--params-file', str(f))]
    arguments += [a for o in overrides for a in ('--set', o)]
    assert main(arguments) == 0
    return list(csv.DictReader((out / 'poses.csv').open()))


def _same_poses(bag: Path, files: list[Path], overrides: list[str], tmp_path: Path) -> None:
    """The primary target's contour over DDS is the offline command's state on every frame, and
    it is published on exactly the frames ``track`` says TRACKING."""
    frames = list(read_frames(bag))
    # The files first: a value of a later file wins over the command line's (the camera's transport).
    args = ['--ros-args', *(a for f in files for a in ('--params-file', str(f)))]
    args += node_arguments(COMPRESSED_CAMERA_TOPIC, True, depth=2 * len(frames))
    args += [a for o in overrides for a in ('-p', o.replace('=', ':=', 1))]
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    collector = replay_and_collect(
        pipeline, bag, COMPRESSED_CAMERA_TOPIC, tmp_path, len(frames), diagnostics_of='/tracker_node'
    )
    rows = _offline(bag, files, overrides, tmp_path / 'offline')
    # The primary target is a followed head (the one nearest the image's centre), or the one target.
    kind = 'head' if any(r['kind'] == 'head' for r in rows) else 'hand'
    followed: dict[int, list[np.ndarray]] = {}
    for r in rows:
        if r['kind'] == kind and r['status'] == 'TRACKING':
            followed.setdefault(int(r['stamp_ns']), []).append(np.array([float(r[k]) for k in POSE]))
    print(f'{bag.name}: {len(followed)} of {len(frames)} frames TRACKING offline, {len(collector.contours)} over DDS')
    assert sorted(collector.contours) == sorted(followed)
    template = make_template(kind)
    for stamp, contour in collector.contours.items():
        state, _ = fit_template(template, contour)
        # poses.csv rounds to 1e-4; the contour travels as float32.
        error = [np.abs(state - offline) / TOLERANCE for offline in followed[stamp]]
        assert min(e.max() for e in error) <= 1.0, (stamp, state, followed[stamp])


@pytest.mark.parametrize('name', list(BAGS))
def test_the_pipeline_over_dds_gives_the_offline_poses_on_every_bag(name: str, tmp_path: Path) -> None:
    files, overrides = BAGS[name]
    _same_poses(REPO / 'bags' / name, files, overrides, tmp_path)


@pytest.mark.skipif(not REAL_DATA.is_dir(), reason='the real sequences are not beside the repository')
@pytest.mark.parametrize('name', list(REAL))
def test_the_pipeline_over_dds_gives_the_offline_poses_on_real_people(name: str, tmp_path: Path) -> None:
    if not (REAL_DATA / name).is_dir():
        pytest.skip(f'{name} is not among the real sequences')
    files, overrides = REAL[name]
    bag, box = _first_frames_as_bag(name, tmp_path)
    init = 'init_box=[' + ', '.join(f'{v:.2f}' for v in box) + ']'
    _same_poses(bag, files, [*overrides, init], tmp_path)


def test_track_refuses_a_misspelt_parameter_as_the_node_does(tmp_path: Path, capsys) -> None:
    bad = tmp_path / 'bad.yaml'
    bad.write_text(CONFIG.read_text().replace('num_particles:', 'num_particels:'))
    track = ['track', str(REPO / 'bags' / 'head_basic'), '--out', str(tmp_path)]
    assert main([*track, '--params-file', str(bad)]) == 2
    error = capsys.readouterr().err
    assert "unknown parameter 'num_particels'" in error and "did you mean 'num_particles'" in error
    assert main([*track, '--set', 'likelihood_gain=-1']) == 2
    assert 'likelihood_gain' in capsys.readouterr().err
    # A node's parameter is set as the node's: not twice, once as an option.
    assert main(['track', 'x', '--set', 'num_particles=200', '--particles', '100']) == 2
    assert '--set num_particles=' in capsys.readouterr().err


def test_a_parameter_set_for_track_reaches_its_frame_path() -> None:
    from human_tracker.ros.configured import configured_pipeline

    configured = configured_pipeline(
        [CONFIG, HAND_CONFIG], ['num_particles=123', 'motion_cue=flow', 'adaptation_rate=0.05', 'min_magnitude=0.7']
    )
    pipeline = configured.pipeline
    assert configured.target == 'hand' and pipeline.people.kinds == ('hand',)
    assert pipeline.people.trackers[0].filter_parameters.num_particles == 123
    assert pipeline.stages.motion_cue == 'flow' and pipeline.stages.motion.parameters.min_magnitude == 0.7
    assert pipeline.stages.adapts_skin and pipeline.stages.skin.adaptation_rate == 0.05


@pytest.mark.parametrize('option', [['--particles', '0'], ['--target', 'person', '--max-people', '0']])
def test_track_refuses_a_zero_given_as_an_option(option: list[str], tmp_path: Path, capsys) -> None:
    """An option given is checked as given, not replaced by its default (0 is not 'left out')."""
    assert main(['track', str(REPO / 'bags' / 'head_basic'), '--out', str(tmp_path), *option]) == 2
    assert 'must be >= 1, ' in capsys.readouterr().err
