"""A person's skin learnt from their face (issue 105): the patches, the class, the guards, and
the labels against skin masks drawn on real frames."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import REPO

from human_tracker.cli import main
from human_tracker.evaluation.skin import labelled_mask_scores, labels_from_faces
from human_tracker.vision.cues.skin import (
    FaceSkin,
    default_skin_model,
    face_skin_class,
    face_skin_mask,
    ohta,
    segment_frame,
)
from human_tracker.vision.cues.skin.face_skin import frame_skin_model
from human_tracker.vision.faces.yunet import YuNetDetector, yunet_available

REAL = REPO.parent / 'shared' / 'data' / 'real'
MASKS = REPO / 'test' / 'data' / 'skin_masks'
DRAWN = ('hand2', 'interview_alberto', 'seated_agbani')

# A face 40 px between the eyes, upright: the person's right eye, left eye, nose tip, mouth corners.
LANDMARKS = ((100.0, 100.0), (140.0, 100.0), (120.0, 125.0), (105.0, 145.0), (135.0, 145.0))
SKIN_BGR = (95, 135, 200)  # I2 = 52.5, I3 = -6.25: inside the general classes
OTHER_SKIN_BGR = (70, 120, 210)  # I2 = 70, I3 = -5: skin too, of another person


def painted_face(colour: tuple[int, int, int], seed: int = 0) -> np.ndarray:
    """A grey frame with a face-sized ellipse of ``colour`` (noise of 4 levels), dark eyes and mouth."""
    rng = np.random.default_rng(seed)
    image = np.full((240, 240, 3), 128, dtype=np.uint8)
    cv2.ellipse(image, (120, 115), (45, 60), 0, 0, 360, colour, -1)
    noise = rng.normal(0.0, 4.0, image.shape)
    image = np.clip(image + noise, 0, 255).astype(np.uint8)
    for x, y in LANDMARKS[:2]:
        cv2.circle(image, (int(x), int(y)), 5, (20, 20, 20), -1)
    cv2.line(image, (105, 145), (135, 145), (40, 40, 120), 3)
    return image


def test_the_patches_are_on_cheeks_forehead_and_nose_bridge_not_on_eyes_or_mouth() -> None:
    mask = face_skin_mask((240, 240), LANDMARKS)
    for x, y in ((100, 122), (140, 122), (120, 75), (120, 109)):  # cheeks, forehead, bridge
        assert mask[y, x]
    for x, y in LANDMARKS:  # eyes, nose tip, mouth corners
        assert not mask[int(y), int(x)]
    assert not mask[145, 120]  # the mouth's middle
    # The frame turns with the face: rotated by 90 degrees, so are the patches.
    turned = face_skin_mask((240, 240), [(239 - y, x) for x, y in LANDMARKS])
    assert np.count_nonzero(turned != np.rot90(mask, k=-1)) < 0.05 * np.count_nonzero(mask)


def test_the_class_is_the_skin_of_the_patches_not_the_hair_over_them() -> None:
    image = painted_face(SKIN_BGR)
    # A fringe over a third of the forehead's patch.
    image[68:82, 100:113] = (30, 30, 40)
    found = face_skin_class(image, LANDMARKS, max_exposure_gain=1.0)  # the colours as painted
    assert found is not None
    np.testing.assert_allclose(found.mean, ohta(np.array(SKIN_BGR, dtype=np.float32))[1:], atol=1.0)
    assert np.all(np.sqrt(np.diag(found.covariance)) < 5.0)
    # Too small a face (eyes 4 px apart) gives no class rather than a guess.
    tiny = [(x / 10.0, y / 10.0) for x, y in LANDMARKS]
    assert face_skin_class(image, tiny) is None


def test_a_face_outside_the_general_model_teaches_nothing() -> None:
    """A face under a green light (its colour far from every general class) is refused."""
    person = FaceSkin(default_skin_model())
    assert not person.observe(painted_face((90, 200, 90)), LANDMARKS)
    assert person.learnt is None and person.model() is person.prior
    assert person.observe(painted_face(SKIN_BGR), LANDMARKS)
    assert person.model().classes == (person.learnt,)


def test_a_lone_jump_is_refused_and_a_lasting_one_relearnt() -> None:
    person = FaceSkin(default_skin_model(), relearn_after=3, max_exposure_gain=1.0)
    assert person.observe(painted_face(SKIN_BGR), LANDMARKS)
    learnt = person.learnt
    assert not person.observe(painted_face(OTHER_SKIN_BGR, seed=1), LANDMARKS)
    assert person.learnt is learnt and person.refused == 1
    # The same face again adapts the class a little, within max_step.
    assert person.observe(painted_face(SKIN_BGR, seed=2), LANDMARKS) and person.refused == 0
    for k in range(3):
        accepted = person.observe(painted_face(OTHER_SKIN_BGR, seed=3 + k), LANDMARKS)
    assert accepted and person.refused == 0
    np.testing.assert_allclose(person.learnt.mean, ohta(np.array(OTHER_SKIN_BGR, dtype=np.float32))[1:], atol=1.0)


def test_a_frame_model_has_a_class_per_face_accepted() -> None:
    prior = default_skin_model()
    image = painted_face(SKIN_BGR)
    assert frame_skin_model(image, [], prior) is prior
    assert len(frame_skin_model(image, [LANDMARKS, LANDMARKS], prior).classes) == 2
    assert frame_skin_model(painted_face((90, 200, 90)), [LANDMARKS], prior) is prior


needs_real = pytest.mark.skipif(
    not all((REAL / name).is_dir() for name in DRAWN) or not yunet_available(),
    reason='real sequences (../shared/data/real) or YuNet absent',
)


@needs_real
def test_the_skin_of_the_face_labels_real_frames_better_than_the_general_classes() -> None:
    """The skin masks drawn on ten frames of each of three colour sequences: the classes learnt
    from each frame's faces label them better than the general classes, and well (F1 >= 0.7)
    where the room holds nothing of the person's skin colour; hand2's orange drawers and wooden
    floor are (docs/decisions/skin-from-the-face.md)."""
    prior = default_skin_model()
    from_faces = labels_from_faces(YuNetDetector().detect, prior)
    for name in DRAWN:
        general = labelled_mask_scores(MASKS / name, REAL / name, lambda image: segment_frame(image, prior))
        faces = labelled_mask_scores(MASKS / name, REAL / name, from_faces)
        assert general['frames'] == faces['frames'] == 10
        assert faces['f1'] > general['f1'] + 0.1, (name, general, faces)
        if name != 'hand2':
            assert faces['f1'] >= 0.7, (name, faces)


@needs_real
def test_the_skin_command_learns_each_frame_from_its_faces(tmp_path: Path, capsys) -> None:
    frames = sorted((REAL / 'interview_alberto' / 'img').iterdir())
    folder = tmp_path / 'in'
    folder.mkdir()
    cv2.imwrite(str(folder / 'face.png'), cv2.imread(str(frames[89])))
    cv2.imwrite(str(folder / 'wall.png'), np.full((120, 160, 3), (95, 135, 200), np.uint8))
    assert main(['skin', str(folder), '--out', str(tmp_path / 'faces')]) == 0
    assert '(1 from the skin of their faces, 1 from the general model)' in capsys.readouterr().out
    assert main(['skin', str(folder), '--out', str(tmp_path / 'general'), '--general']) == 0
    truth = cv2.imread(str(MASKS / 'interview_alberto' / '0089.png'), cv2.IMREAD_GRAYSCALE) > 0
    scores = {}
    for kind in ('faces', 'general'):
        labels = cv2.imread(str(tmp_path / kind / 'face.png'), cv2.IMREAD_GRAYSCALE) > 0
        scores[kind] = 2.0 * np.count_nonzero(labels & truth) / (np.count_nonzero(labels) + np.count_nonzero(truth))
        # A skin-coloured wall with no face: the general classes label it either way.
        assert (cv2.imread(str(tmp_path / kind / 'wall.png'), cv2.IMREAD_GRAYSCALE) > 0).mean() > 0.9
    assert scores['faces'] > scores['general'] + 0.1, scores
