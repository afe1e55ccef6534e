"""How well the skin labels (§3.2) cover true skin: pixel precision and recall, regions found.

Truth comes from the scene generator (exact skin of the face and the hand, frames read back
from the bundled JPEG bags), from hand-labelled boxes of real frames (a JSON file of
inclusive ``[x0, y0, x1, y1]`` boxes per frame index) or from skin masks drawn on real frames
(``test/data/skin_masks``: :func:`labelled_mask_scores`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import cv2
import numpy as np

from human_tracker.io.sequences import open_sequence
from human_tracker.scenes.generator import SCENES, render_scene
from human_tracker.vision.cues.skin import (
    SkinModel,
    SkinParameters,
    default_skin_model,
    frame_skin_model,
    segment_frame,
    segment_skin,
)
from human_tracker.vision.faces.detector import Detection

__all__ = [
    'box_mask',
    'labelled_mask_scores',
    'labels_from_faces',
    'labelled_photo_scores',
    'labelled_video_scores',
    'scene_scores',
    'skin_scores',
]


def box_mask(shape: tuple[int, int], boxes: Sequence[Sequence[int]]) -> np.ndarray:
    """``(H, W) bool`` mask, True inside the inclusive boxes ``[x0, y0, x1, y1]``."""
    mask = np.zeros(shape, dtype=bool)
    for x0, y0, x1, y1 in boxes:
        mask[y0 : y1 + 1, x0 : x1 + 1] = True
    return mask


def _pixel_counts(labels: np.ndarray, skin: np.ndarray) -> tuple[int, int, int]:
    """Skin pixels labelled skin, pixels labelled skin, true skin pixels of one frame."""
    labelled = np.asarray(labels) > 0
    return int(np.count_nonzero(labelled & skin)), int(np.count_nonzero(labelled)), int(np.count_nonzero(skin))


def skin_scores(predicted: Sequence[np.ndarray], truth: Sequence[np.ndarray]) -> dict[str, float | int]:
    """Pixel precision and recall over frames, and how many true skin regions got any label.

    Args:
        predicted: ``(H, W)`` skin labels per frame (non-zero: skin).
        truth: ``(H, W) bool`` true skin per frame.

    Returns:
        ``precision``, ``recall`` (pixels, all frames pooled; precision is 0 with no label),
        ``labelled_fraction`` (of all pixels), ``regions`` (8-connected true regions) and
        ``regions_found`` (those with at least one pixel labelled skin).
    """
    hits = labelled = true = pixels = regions = found = 0
    for labels, skin in zip(predicted, truth, strict=True):
        labels = np.asarray(labels) > 0
        counts = _pixel_counts(labels, skin)
        hits, labelled, true = hits + counts[0], labelled + counts[1], true + counts[2]
        pixels += labels.size
        count, components = cv2.connectedComponents(skin.astype(np.uint8), connectivity=8)
        regions += count - 1
        found += len(np.setdiff1d(np.unique(components[labels]), [0]))
    return {
        'precision': round(hits / labelled, 4) if labelled else 0.0,
        'recall': round(hits / true, 4) if true else float('nan'),
        'labelled_fraction': round(labelled / pixels, 4) if pixels else 0.0,
        'regions': regions,
        'regions_found': found,
    }


def scene_scores(
    bag: Path, model: SkinModel | None = None, parameters: SkinParameters | None = None, step: int = 10
) -> dict[str, float | int]:
    """Scores on every ``step``-th frame of a bundled scene bag, against the generator's true skin."""
    spec = SCENES[bag.name]
    truth = [f.skin for f in render_scene(spec)][::step]
    images = [f.image for f in open_sequence(bag)][::step]
    model = model or default_skin_model()
    return skin_scores([segment_skin(image, model, parameters) for image in images], truth)


def labelled_video_scores(
    labels: Path, real_data: Path, model: SkinModel | None = None, parameters: SkinParameters | None = None
) -> dict[str, float | int]:
    """Scores on the hand-labelled frames of a real video (``labels`` names the video under ``real_data``)."""
    spec = json.loads(labels.read_text())
    capture = cv2.VideoCapture(str(real_data / spec['source']))
    model = model or default_skin_model()
    predicted, truth = [], []
    try:
        for index, boxes in sorted(spec['frames'].items(), key=lambda item: int(item[0])):
            capture.set(cv2.CAP_PROP_POS_FRAMES, int(index))
            ok, image = capture.read()
            if not ok:
                raise ValueError(f'{spec["source"]}: frame {index} cannot be read')
            predicted.append(segment_skin(image, model, parameters))
            truth.append(box_mask(image.shape[:2], boxes))
    finally:
        capture.release()
    return skin_scores(predicted, truth)


def labelled_photo_scores(
    folder: Path, model: SkinModel | None = None, parameters: SkinParameters | None = None
) -> dict[str, float | int]:
    """Scores on photos with pixel skin masks, laid out as HGR's (``../shared/data/skin/hgr``).

    ``folder/images/<name>.jpg`` and ``folder/masks/<name>.bmp`` (0 = skin). Each photo is
    segmented at its own size.

    Returns:
        ``photos``; ``precision``, ``recall`` and ``f1`` of the skin pixels, all photos pooled;
        ``mean_photo_f1``, the F1 of each photo averaged.
    """
    model = model or default_skin_model()
    hits = labelled = true = 0
    photo_f1 = []
    for path in sorted((folder / 'images').glob('*.jpg')):
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        truth = cv2.imread(str(folder / 'masks' / f'{path.stem}.bmp'), cv2.IMREAD_GRAYSCALE)
        if image is None or truth is None:
            raise ValueError(f'{path.name}: the photo or its mask cannot be read')
        photo_hits, photo_labelled, photo_true = _pixel_counts(segment_skin(image, model, parameters), truth == 0)
        hits, labelled, true = hits + photo_hits, labelled + photo_labelled, true + photo_true
        photo_f1.append(2.0 * photo_hits / (photo_labelled + photo_true) if photo_labelled + photo_true else 1.0)
    precision = hits / labelled if labelled else 0.0
    recall = hits / true if true else float('nan')
    return {
        'photos': len(photo_f1),
        'precision': round(precision, 4),
        'recall': round(recall, 4),
        'f1': round(2.0 * hits / (labelled + true), 4) if labelled + true else float('nan'),
        'mean_photo_f1': round(float(np.mean(photo_f1)), 4) if photo_f1 else float('nan'),
    }


def labels_from_faces(
    detect: Callable[[np.ndarray], Sequence[Detection]], prior: SkinModel | None = None
) -> Callable[[np.ndarray], np.ndarray]:
    """A frame's skin labels (:func:`~human_tracker.vision.cues.skin.segment_frame`) from the
    classes of the faces ``detect`` finds in it
    (:func:`~human_tracker.vision.cues.skin.frame_skin_model`), the ``prior`` (the general
    classes) where it finds none."""
    prior = prior or default_skin_model()

    def labels_of(image: np.ndarray) -> np.ndarray:
        faces = [face.landmarks for face in detect(image)]
        return segment_frame(image, frame_skin_model(image, faces, prior))

    return labels_of


def labelled_mask_scores(
    masks: Path, sequence: Path, labels_of: Callable[[np.ndarray], np.ndarray]
) -> dict[str, float]:
    """Scores of ``labels_of`` (a BGR frame to its ``(H, W)`` skin labels, non-zero: skin) on the
    frames of a real sequence with drawn skin masks.

    Args:
        masks: Folder of ``<index>.png`` masks (255: skin), ``index`` the frame's position in the
            sequence's sorted ``img/`` folder.
        sequence: The sequence's folder.

    Returns:
        ``frames``; ``precision``, ``recall`` and ``f1`` of the skin pixels, all frames pooled.
    """
    frames = sorted((sequence / 'img').iterdir())
    hits = labelled = true = 0
    paths = sorted(masks.glob('*.png'))
    for path in paths:
        truth = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        image = cv2.imread(str(frames[int(path.stem)]), cv2.IMREAD_COLOR)
        if truth is None or image is None or truth.shape != image.shape[:2]:
            raise ValueError(f'{path}: the mask or its frame cannot be read, or their sizes differ')
        counts = _pixel_counts(labels_of(image), truth > 0)
        hits, labelled, true = hits + counts[0], labelled + counts[1], true + counts[2]
    return {
        'frames': len(paths),
        'precision': round(hits / labelled, 4) if labelled else 0.0,
        'recall': round(hits / true, 4) if true else float('nan'),
        'f1': round(2.0 * hits / (labelled + true), 4) if labelled + true else float('nan'),
    }
