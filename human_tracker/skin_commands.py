"""The ``human_tracker train-skin`` and ``human_tracker skin`` commands: the skin classes of §3.2
learnt from labelled colours, and the skin labels of images."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from human_tracker.vision.checks import description_of
from human_tracker.vision.cues.skin.parameters import SkinParameters

__all__ = ['add_skin_commands', 'skin_help']


def skin_help(name: str) -> str:
    """The help of an option that sets the skin stage's ``name``: its declared meaning."""
    return description_of(SkinParameters, name)


def _train_skin(options: argparse.Namespace) -> int:
    from human_tracker.io.skin_samples import read_skin_samples
    from human_tracker.vision.cues.skin import train_skin_model

    colours, is_skin = read_skin_samples(options.samples)
    model = train_skin_model(
        colours, is_skin, num_classes=options.classes, skin_coverage=options.coverage, seed=options.seed
    )
    model.notes['source'] = Path(options.samples).name
    options.out.parent.mkdir(parents=True, exist_ok=True)
    options.out.write_text(model.to_json() + '\n')
    print(json.dumps(model.notes, indent=2))
    print(f'human_tracker train-skin: wrote {options.out} ({len(model.classes)} classes)')
    return 0


def _skin(options: argparse.Namespace) -> int:
    import cv2
    import numpy as np

    from human_tracker.io.frames import open_frames
    from human_tracker.vision.cues.skin import (
        SkinModel,
        SkinParameters,
        default_skin_model,
        frame_skin_model,
        has_colour,
        segment_frame,
    )

    source = open_frames(options.input)
    model = SkinModel.load(options.model) if options.model else default_skin_model()
    parameters = SkinParameters(
        colour_blur=options.colour_blur, regions=options.regions, merge_distance=options.merge_distance
    )
    parameters.validate()
    detector = None
    if not options.general:
        from human_tracker.vision.faces.yunet import YuNetDetector

        detector = YuNetDetector()
    options.out.mkdir(parents=True, exist_ok=True)
    written, unreadable, grey, from_faces = 0, [], 0, 0
    labelled = 0.0
    try:
        for index, image in enumerate(source):
            stem = source.files[index].stem if source.files else f'{Path(options.input).stem}_{index:06d}'
            if image is None:
                unreadable.append(stem)
                continue
            if not has_colour(image):
                grey += 1  # no chromaticity: written as no skin, counted
                mask = np.zeros(image.shape[:2], np.uint8)
            else:
                frame_model = model
                if detector is not None:
                    faces = [face.landmarks for face in detector.detect(image)]
                    frame_model = frame_skin_model(image, faces, model, parameters.max_exposure_gain)
                    from_faces += frame_model is not model
                mask = segment_frame(image, frame_model, parameters, options.working_width)
            cv2.imwrite(str(options.out / f'{stem}.png'), np.where(mask > 0, 255, 0).astype(np.uint8))
            written += 1
            labelled += float(np.count_nonzero(mask)) / mask.size
    finally:
        source.close()
    faces_said = ''
    if detector is not None:
        faces_said = (
            f' ({from_faces} from the skin of their faces, {written - from_faces - grey} from the general model)'
        )
    print(
        f'human_tracker skin: wrote {written} masks (255 = skin) to {options.out}{faces_said}; '
        f'{labelled / max(written, 1):.1%} of the pixels labelled skin on average'
    )
    if grey:
        print(f'human_tracker skin: {grey} grey-level frames (no colour, no skin)', file=sys.stderr)
    if unreadable:
        print(f'human_tracker skin: {len(unreadable)} unreadable images: {", ".join(unreadable)}', file=sys.stderr)
        return 1
    return 0


def add_skin_commands(commands: argparse._SubParsersAction) -> None:
    """``train-skin`` and ``skin`` under ``commands``."""
    trainer = commands.add_parser('train-skin', help='learn the skin classes of §3.2 from labelled colour samples')
    trainer.add_argument('samples', help='text file of "B G R class" lines, class 1 skin / 2 non-skin (UCI format)')
    # Required: nothing the package ships (its own skin_model.json) is written unless named.
    trainer.add_argument('--out', type=Path, required=True, help='JSON file to write the classes to')
    trainer.add_argument('--classes', type=int, default=4, help='number of skin classes (default 4)')
    trainer.add_argument(
        '--coverage', type=float, default=0.95, help='fraction of skin samples the classes cover (default 0.95)'
    )
    trainer.add_argument('--seed', type=int, default=0)
    trainer.set_defaults(run=_train_skin)

    skin = commands.add_parser(
        'skin',
        help="skin labels (§3.2) of a folder of images or a video, one PNG mask each, from the skin of each frame's "
        'faces (the general classes where none is found)',
    )
    skin.add_argument('input', help='folder of images (masks keep their file stems) or video file')
    skin.add_argument('--out', type=Path, required=True, help='folder to write the masks to (255 = skin)')
    skin.add_argument(
        '--model',
        type=Path,
        help='general skin classes (JSON from train-skin; default: the shipped ones): the prior a face must fit, '
        'and the labels of a frame without a face',
    )
    skin.add_argument(
        '--general',
        action='store_true',
        help="label every frame with the general classes (default: each frame's skin learnt from its faces)",
    )
    skin.add_argument(
        '--regions',
        choices=('cells', 'pixels'),
        default='cells',
        help='phase 1: cells (the paper) or pixels (seed pixels grown by hysteresis: finds small skin regions)',
    )
    skin.add_argument(
        '--colour-blur',
        type=float,
        default=0.0,
        metavar='SIGMA',
        help=skin_help('colour_blur'),
    )
    skin.add_argument('--merge-distance', type=float, default=0.0, metavar='D', help=skin_help('merge_distance'))
    skin.add_argument(
        '--working-width',
        type=int,
        default=320,
        help='frames wider than this are segmented at this width, as the skin stage does (0: full size)',
    )
    skin.set_defaults(run=_skin)
