"""The ``human_tracker`` command: offline tools around the tracker (no ROS graph needed)."""

from __future__ import annotations

import argparse
import json
import logging
import shutil
import sys
from pathlib import Path
from typing import TypeVar

from human_tracker.graph_commands import add_graph_commands
from human_tracker.io.bags import BagError
from human_tracker.io.frames import FrameSourceError
from human_tracker.io.sequences import SequenceError, sequence_name
from human_tracker.skin_commands import add_skin_commands
from human_tracker.skin_commands import skin_help as _skin_help

__all__ = ['main']

_T = TypeVar('_T')


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


def _box(text: str) -> tuple[float, float, float, float]:
    try:
        values = tuple(float(v) for v in text.split(','))
    except ValueError:
        values = ()
    if len(values) != 4 or values[2] <= 0 or values[3] <= 0:
        raise argparse.ArgumentTypeError(f'expected x,y,w,h with w, h > 0, got {text!r}')
    return values  # type: ignore[return-value]


# The options of ``track`` a parameter file sets as the node's parameters, with their names there.
_NODE_PARAMETER_OPTIONS = {
    'target': 'target',
    'hands': 'hands',
    'max_people': 'max_people',
    'cue': 'motion_cue',
    'skin': 'skin_cue',
    'colour_blur': 'colour_blur',
    'merge_distance': 'merge_distance',
    'template': 'template_file',
    'particles': 'num_particles',
    'working_width': 'working_width',
}


def _given(value: _T | None, default: _T) -> _T:
    """An option's value, or ``default`` where it was left out (None)."""
    return default if value is None else value


def _track(options: argparse.Namespace) -> int:
    from human_tracker.offline import TrackOptions, track_sequence
    from human_tracker.threads import default_threads, use_threads
    from human_tracker.vision.cues.skin import SkinParameters
    from human_tracker.vision.filter.contour_filter import TrackerParameters

    use_threads(default_threads() if options.threads is None else options.threads)
    out = options.out or Path('out') / 'track' / sequence_name(Path(options.input))
    shown = {
        'init': options.init,
        'init_kind': options.init_kind,
        'video': not options.no_video,
        'video_every': options.video_every,
        'progress': not options.quiet,
        'fps': options.fps,
    }
    if options.params_file or options.set:
        from human_tracker.ros.configured import configured_pipeline

        given = [name for name in _NODE_PARAMETER_OPTIONS if getattr(options, name) is not None]
        if given:
            flags = ', '.join(f'--{n.replace("_", "-")} (--set {_NODE_PARAMETER_OPTIONS[n]}=...)' for n in given)
            raise ValueError(f'with --params-file or --set, give the node parameters instead: {flags}')
        seed = [] if options.seed is None else [f'seed={options.seed}']
        configured = configured_pipeline(options.params_file, [*options.set, *seed])
        shown['init'] = options.init or configured.init_box
        settings = TrackOptions(target=configured.target, pipeline=configured.pipeline, **shown)
    else:
        # The options left out take their defaults; one given (a 0 too) is checked as given.
        settings = TrackOptions(
            target=options.target,
            hands=_given(options.hands, 1),
            max_people=_given(options.max_people, 1),
            cue=_given(options.cue, 'background'),
            skin=options.skin,
            skin_parameters=SkinParameters(
                colour_blur=_given(options.colour_blur, 0.0), merge_distance=_given(options.merge_distance, 0.0)
            ),
            template_file=options.template or '',
            filter_parameters=TrackerParameters(
                num_particles=_given(options.particles, 500), seed=_given(options.seed, 0)
            ),
            working_width=options.working_width,
            **shown,
        )
    summary = track_sequence(options.input, out, settings)
    print(json.dumps(summary, indent=2))
    print(
        f'human_tracker track: wrote {out}/poses.csv, summary.json'
        + ('' if options.no_video else ', tracking.mp4')
        + ', plots'
    )
    return 0


def _has_frames(folder: Path) -> bool:
    """Whether ``folder`` holds a bag or images (in it or in ``img/``), not just a ground truth."""
    from human_tracker.io.frames import IMAGE_SUFFIXES

    files = [*folder.iterdir(), *((folder / 'img').iterdir() if (folder / 'img').is_dir() else [])]
    return any(f.suffix.lower() in (*IMAGE_SUFFIXES, '.mcap', '.db3', '.yaml') for f in files)


def _eval(options: argparse.Namespace) -> int:
    from human_tracker.evaluation.identity import identity_scores, one_track
    from human_tracker.evaluation.metrics import summarise
    from human_tracker.io.poses import read_ids, read_tracks
    from human_tracker.io.sequences import open_sequence, read_groundtruth

    tracks = read_tracks(options.poses)
    truth_path = Path(options.truth)
    if truth_path.is_dir() and (truth_path / 'groundtruth.txt').is_file() and not _has_frames(truth_path):
        truth_path = truth_path / 'groundtruth.txt'  # a sequence's folder holding only its ground truth
    truth = (
        read_groundtruth(truth_path)
        if truth_path.is_file() and truth_path.suffix == '.txt'
        else [f.ground_truth for f in open_sequence(truth_path)]
    )
    frames = len(next(iter(tracks.values())))
    if not any(box is not None for box in truth):
        print(f"human_tracker eval: no ground truth in {truth_path} (groundtruth.txt, or a bag's)", file=sys.stderr)
        return 2
    if len(truth) != frames:
        print(f'human_tracker eval: {frames} poses but {len(truth)} ground-truth frames', file=sys.stderr)
        return 2
    # A person's table: the ground truth is scored against the target that matches it best.
    scores = {kind: summarise(boxes, truth) for kind, boxes in tracks.items()}
    kind = max(scores, key=lambda k: scores[k]['precision_20px'])
    identity = identity_scores({'truth': truth}, one_track(read_ids(options.poses)[kind], tracks[kind]))
    print(json.dumps({**scores[kind], **identity, **({'scored_kind': kind} if kind else {})}, indent=2))
    return 0


def _compare(options: argparse.Namespace) -> int:
    from human_tracker.evaluation.accuracy import compare_on_folder, real_people_table

    contrib = options.contrib_python
    if contrib is not None and not contrib.exists():
        raise ValueError(f'--contrib-python {contrib} does not exist (make bench creates .venv-contrib)')
    rows = []
    for row in compare_on_folder(options.folder, contrib):
        rows.append(row)
        print(f'{row["sequence"]}: {row["tracker"]} {row["precision_20px_mean"]:.3f}', file=sys.stderr)
    if not rows:
        raise ValueError(f'{options.folder} holds no sequence (a sub-folder with a groundtruth.txt)')
    options.out.mkdir(parents=True, exist_ok=True)
    table = real_people_table(rows)
    (options.out / 'compare.json').write_text(json.dumps(rows, indent=2) + '\n')
    (options.out / 'compare.md').write_text(table)
    print(table)
    return 0


def _import(options: argparse.Namespace) -> int:
    from human_tracker.io.bags import write_bag
    from human_tracker.io.sequences import open_sequence, read_groundtruth

    sequence = open_sequence(options.input)
    extra = read_groundtruth(Path(options.groundtruth)) if options.groundtruth else None
    if options.out.exists():
        print(f'human_tracker import: {options.out} exists; choose a new folder', file=sys.stderr)
        return 2

    def frames():
        for frame in sequence:
            box = extra[frame.index] if extra is not None and frame.index < len(extra) else frame.ground_truth
            yield frame.stamp_ns, frame.image, box

    write_bag(options.out, frames(), storage=options.storage, target=options.target)
    print(f'human_tracker import: wrote {options.out}')
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
    # Required: the bundled bags are replaced only when asked for by name (`make bags`).
    generate.add_argument(
        '--out', type=Path, required=True, help='folder for the bags (bags/ replaces the bundled ones)'
    )
    generate.add_argument('--raw', action='store_true', help='raw bgr8 Image instead of JPEG CompressedImage')
    generate.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap')
    generate.set_defaults(run=_generate)

    track = commands.add_parser(
        'track', help='track a bag, a video file or a folder of frames, offline and as fast as possible'
    )
    track.add_argument(
        'input', help='bag (folder, .mcap, .db3), video file, or folder of frames (optional groundtruth.txt)'
    )
    track.add_argument(
        '--target',
        choices=('head', 'hand', 'person'),
        help='what to track: a head, a hand, or a person (head and hand, each with its id; default: what the '
        'ground truth outlines, or head)',
    )
    track.add_argument(
        '--init', type=_box, metavar='X,Y,W,H', help='box of the target in the first frame (default: start from motion)'
    )
    track.add_argument(
        '--init-kind',
        choices=('head', 'hand'),
        help='with --target person: which target --init is the box of (default: what the ground truth outlines, '
        'or head)',
    )
    track.add_argument(
        '--hands', type=int, choices=(0, 1, 2), help="with --target person: a person's hands (default 1)"
    )
    track.add_argument(
        '--max-people',
        type=int,
        metavar='N',
        help='with --target person: the most people followed at once, each with its ids (default 1)',
    )
    track.add_argument(
        '--out',
        type=Path,
        help="output folder (default out/track/<sequence name>: a folder's or file's name, "
        "the parent's for an img/ folder)",
    )
    track.add_argument('--cue', choices=('background', 'flow', 'none'), help='motion cue (default background)')
    track.add_argument(
        '--skin',
        action=argparse.BooleanOptionalAction,
        help='segment skin and use it in the likelihood (default: on for --target hand)',
    )
    track.add_argument('--colour-blur', type=float, metavar='SIGMA', help=_skin_help('colour_blur'))
    track.add_argument('--merge-distance', type=float, metavar='D', help=_skin_help('merge_distance'))
    track.add_argument('--template', help='JSON template file replacing the built-in one')
    track.add_argument('--particles', type=int, metavar='P', help="particles of each target's filter (default 500)")
    track.add_argument(
        '--seed',
        type=int,
        help='seed of the random generators: the same seed on the same input gives the same poses (default 0)',
    )
    track.add_argument(
        '--working-width',
        type=int,
        help='frames wider than this are reduced to it before tracking (default 320; 0: full size)',
    )
    track.add_argument('--no-video', action='store_true', help='skip the annotated video')
    track.add_argument('--video-every', type=int, default=1, help='write every Nth frame to the video (default 1)')
    track.add_argument(
        '--fps',
        type=float,
        help="frame rate of a folder of frames or a video, stamping its frames (default: the video's, or 30)",
    )
    track.add_argument('--quiet', action='store_true', help='no progress bar')
    track.add_argument(
        '--params-file',
        action='append',
        default=[],
        metavar='FILE',
        help="the nodes' parameter file (config/human_tracker.yaml's form; repeatable): track with the frame "
        'path the pipeline node builds from it, every key checked as the node checks it',
    )
    track.add_argument(
        '--set',
        action='append',
        default=[],
        metavar='NAME=VALUE',
        help='a node parameter, after the files (as -p NAME:=VALUE; repeatable)',
    )
    track.add_argument(
        '--threads',
        type=int,
        help='threads of the parallel loops (default: HUMAN_TRACKER_THREADS, else 1; 0: every core)',
    )
    track.set_defaults(run=_track)

    evaluate = commands.add_parser('eval', help='score a poses.csv against ground truth (OTB metrics)')
    evaluate.add_argument('poses', type=Path, help='poses.csv written by track')
    evaluate.add_argument('truth', help='groundtruth.txt, or the sequence (bag or folder) that holds it')
    evaluate.set_defaults(run=_eval)

    compare = commands.add_parser(
        'compare', help='ours (5 seeds, with and without a first box), the paper and OpenCV on a folder of sequences'
    )
    compare.add_argument('folder', type=Path, help='folder of sequences (sub-folders with a groundtruth.txt)')
    compare.add_argument('--out', type=Path, default=Path('out/compare'), help='folder for compare.md and .json')
    compare.add_argument(
        '--contrib-python', type=Path, help='python of a virtualenv with opencv-contrib (adds KCF and CSRT)'
    )
    compare.set_defaults(run=_compare)

    importer = commands.add_parser('import', help='a folder of frames or a video (with ground truth) into a bag')
    importer.add_argument('input', help='video file or folder of frames (optional groundtruth.txt)')
    importer.add_argument('--out', type=Path, required=True, help='bag folder to create')
    importer.add_argument('--groundtruth', help='groundtruth.txt (default: the folder own)')
    importer.add_argument(
        '--target',
        choices=('head', 'hand'),
        default='head',
        help='what the ground truth outlines (topic /ground_truth/<target>; default head)',
    )
    importer.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap')
    importer.set_defaults(run=_import)

    add_graph_commands(commands)
    add_skin_commands(commands)

    options = parser.parse_args(argv)
    # What the library warns of (a truncated video, frames without colour) reaches the user.
    logging.basicConfig(level=logging.WARNING, format=f'human_tracker {options.command}: %(levelname)s: %(message)s')
    try:
        return int(options.run(options))
    except (SequenceError, BagError, FrameSourceError, ValueError, OSError) as err:
        print(f'human_tracker {options.command}: error: {err}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
