"""Nothing silent on a robot: a node wired to a topic nobody publishes says so, in its log and in
``/diagnostics``, naming the topic and transport it listens on and the image topics the graph
has, instead of reporting OK at 0 Hz; ``bag_play`` refuses what it cannot do and names it."""

from __future__ import annotations

import csv
import os
import re
import time
from pathlib import Path

from conftest import REPO
from ros_harness import collecting, environment, run_bag_play
from sensor_msgs.msg import CompressedImage

from human_tracker.cli import main
from human_tracker.demo import run_demo
from human_tracker.io.poses import POSE_COLUMNS
from human_tracker.io.sequences import write_groundtruth
from human_tracker.ros.processes import NodeProcess


def test_a_pipeline_that_receives_no_frame_says_where_it_listens_and_what_is_published(tmp_path: Path) -> None:
    # The README's trap: a bag's compressed camera replayed into a pipeline listening raw.
    args = ['--ros-args', '-p', 'no_input_warning:=2.0', '-r', 'image:=/camera/image_raw']
    pipeline = NodeProcess('human_tracker.ros.pipeline', args, environment(), tmp_path / 'pipeline.log')
    with collecting() as (collector, executor):
        camera = collector.create_publisher(CompressedImage, '/camera/image_raw/compressed', 10)
        try:
            pipeline.start()
            deadline = time.monotonic() + 90.0
            status: dict[str, str] = {}
            while time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.1)
                status = collector.diagnostics.get('/camera_subscriber', {})
                if 'NO_INPUT' in status.get('warnings', ''):
                    break
            assert 'NO_INPUT' in status.get('warnings', ''), pipeline.output()
            assert status['frames_received'] == '0' and status['ready'] == 'True'
            said = status['warnings']
            assert '/camera/image_raw (raw, 0 publishers)' in said, said
            assert '/camera/image_raw/compressed (compressed)' in said and 'image_transport:=compressed' in said
            # The masks and views of the package's own nodes are not offered as cameras.
            assert '/foreground' not in said
        finally:
            pipeline.stop()
            collector.destroy_publisher(camera)
    log = pipeline.output()
    assert 'no frame for' in log and '/camera/image_raw/compressed (compressed)' in log
    # In the order things happen, nothing false for the layout: configured, then active.
    tracker = [line for line in log.splitlines() if '[tracker_node]' in line]
    said = [next(i for i, line in enumerate(tracker) if word in line) for word in ('configured:', ': active')]
    assert said == sorted(said) and 'cues measured in process' in tracker[said[0]], tracker
    assert 'mask inputs' not in log


def test_bag_play_refuses_a_remap_of_a_topic_the_bag_lacks_and_lists_its_topics() -> None:
    # The README's replay names the compressed topic; the raw one is not in the bag.
    played = run_bag_play(str(REPO / 'bags' / 'head_basic'), '--remap', '/camera/image_raw:=/image')
    assert played.returncode == 1, played.stderr
    assert '--remap: /camera/image_raw not in' in played.stderr
    assert '/camera/image_raw/compressed' in played.stderr and '/camera/camera_info' in played.stderr


def test_bag_play_on_an_empty_folder_names_what_is_missing(tmp_path: Path) -> None:
    played = run_bag_play(str(tmp_path))
    assert played.returncode == 1
    assert 'no metadata.yaml beside it and not one .mcap file' in played.stderr
    assert "Expected metadata file '" not in played.stderr


def test_the_graph_can_be_looked_at_from_the_virtualenv(tmp_path: Path, capsys) -> None:
    """``topics``, ``echo`` and ``call``: what ros2cli does on a robot."""
    node = NodeProcess('human_tracker.ros.background_node', [], environment(), tmp_path / 'background.log')
    with node:
        deadline = time.monotonic() + 60.0
        while 'ready' not in node.output() and time.monotonic() < deadline:
            time.sleep(0.2)
        # A busy machine's discovery may not have reached the node, or matched the listing's
        # subscription to its 1 Hz diagnostics, on the first look: look again.
        for _ in range(3):
            assert main(['topics', '--seconds', '3']) == 0
            listed = capsys.readouterr().out
            line = next((line for line in listed.splitlines() if line.startswith('/diagnostics ')), listed)
            if line.startswith('/diagnostics ') and not line.endswith(' 0.0 Hz'):
                break
        assert re.fullmatch(r'/diagnostics \[diagnostic_msgs/msg/DiagnosticArray\] [1-9]\d* publishers, .*Hz', line)
        assert not line.endswith(' 0.0 Hz'), line
        assert main(['echo', '/diagnostics']) == 0
        assert "name: '/background_node'" in capsys.readouterr().out
        assert main(['call', '/background_node/reset']) == 0
        assert "success: True, message: 'background model reset" in capsys.readouterr().out
        assert main(['echo', '/nope', '--timeout', '1']) == 2
        assert 'no topic /nope on the graph' in capsys.readouterr().err


def test_eval_scores_against_a_sequence_folder_that_holds_only_its_ground_truth(tmp_path: Path, capsys) -> None:
    truth = [(10.0, 20.0, 30.0, 40.0), None, (12.0, 20.0, 30.0, 40.0)]
    write_groundtruth(tmp_path / 'groundtruth.txt', truth)
    poses = tmp_path / 'poses.csv'
    with poses.open('w', newline='') as handle:
        table = csv.DictWriter(handle, POSE_COLUMNS)
        table.writeheader()
        for index, box in enumerate(truth):
            cells = dict(zip(('box_x', 'box_y', 'box_w', 'box_h'), box or ('',) * 4, strict=True))
            table.writerow({'frame': index, 'status': 'TRACKING' if box else 'LOST', 'kind': 'head', **cells})
    assert main(['eval', str(poses), str(tmp_path)]) == 0, capsys.readouterr().err
    assert '"precision_20px": 1.0' in capsys.readouterr().out


def test_the_demo_says_how_it_started_and_measures_processing_and_latency(tmp_path: Path) -> None:
    """No 'fps' counted from the replay's start (warm-up included): the nodes' own processing
    time per frame and the latency from each frame to its pose."""
    summary = run_demo(REPO / 'bags' / 'head_basic', tmp_path / 'demo', domain_id=int(os.environ['ROS_DOMAIN_ID']))
    assert 'fps' not in summary and summary['start'].startswith("from the first frame's ground-truth box")
    assert set(summary['processing_ms_per_frame']) == {'background_node', 'tracker_node'}
    assert all(ms > 0 for ms in summary['processing_ms_per_frame'].values()) and summary['processing_fps'] > 0
    assert 0 < summary['latency_ms_median'] <= summary['latency_ms_p95']
