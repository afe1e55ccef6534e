"""Skin segmentation of §3.2: I1I2I3, cells, merging, histogram modes, classes; hand-computed values."""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest
from conftest import REPO
from scipy.special import erfinv

from human_tracker.cli import main
from human_tracker.evaluation.skin import labelled_photo_scores
from human_tracker.io.bags import read_frames
from human_tracker.io.images import message_to_bgr8
from human_tracker.io.skin_samples import read_skin_samples
from human_tracker.scenes.generator import SCENES, render_scene
from human_tracker.vision.cues.skin import (
    MIXED_SKIN,
    SkinClass,
    SkinModel,
    SkinParameters,
    SkinSegmenter,
    candidate_cells,
    cell_chroma,
    default_skin_model,
    has_colour,
    histogram_modes,
    hysteresis_regions,
    merge_cells,
    ohta,
    segment_skin,
    train_skin_model,
)
from human_tracker.vision.cues.skin.clusters import _two_means as two_means

SKIN_SAMPLES = REPO.parent / 'shared' / 'data' / 'skin' / 'Skin_NonSkin.txt'
HGR = REPO.parent / 'shared' / 'data' / 'skin' / 'hgr'
SKIN_BGR = (95, 135, 200)  # I2 = 52.5, I3 = -6.25: inside the learnt classes


def _one_class(mean: tuple[float, float], variance: float = 1.0, match: float = 1.0) -> SkinModel:
    return SkinModel((SkinClass(np.array(mean, dtype=float), np.eye(2) * variance),), match)


def test_ohta_components_by_hand() -> None:
    # B, G, R = 10, 20, 40: I1 = 70 / 3, I2 = (40 - 10) / 2 = 15, I3 = (40 - 40 - 10) / 4 = -2.5.
    np.testing.assert_allclose(ohta(np.array([[10, 20, 40]], dtype=np.uint8))[0], [70 / 3, 15.0, -2.5], rtol=1e-6)
    grey = ohta(np.full((2, 2, 3), 128, dtype=np.uint8))
    np.testing.assert_allclose(grey[..., 1:], 0.0)  # a grey level has no chromaticity
    with pytest.raises(ValueError, match='B, G, R'):
        ohta(np.zeros((4, 4), dtype=np.uint8))


def test_grey_frames_have_no_colour() -> None:
    grey = np.full((4, 4, 3), 90, dtype=np.uint8)
    assert not has_colour(grey) and not has_colour(grey[..., 0])
    grey[0, 0] = SKIN_BGR
    assert has_colour(grey)


def test_mahalanobis_distance_by_hand() -> None:
    skin_class = SkinClass(np.array([0.0, 0.0]), np.diag([4.0, 1.0]))
    assert skin_class.distance(np.array([2.0, 1.0])) == pytest.approx(np.sqrt(2.0))
    model = SkinModel((skin_class, SkinClass(np.array([10.0, 0.0]), np.eye(2))), 1.0)
    assert model.distance(np.array([9.0, 0.0])) == pytest.approx(1.0)
    assert int(model.nearest(np.array([9.0, 0.0]))) == 1
    # Any shape of (..., 2) values: the nearest class's own distance, value for value.
    chroma = np.random.default_rng(0).uniform(-20.0, 30.0, (5, 7, 2))
    per_class = np.array([c.distance(chroma) for c in model.classes])
    assert model.distance(chroma).shape == model.nearest(chroma).shape == (5, 7)
    np.testing.assert_array_equal(model.distance(chroma), per_class.min(axis=0))
    np.testing.assert_array_equal(model.nearest(chroma), per_class.argmin(axis=0))


def test_candidate_cells_use_the_cell_mean() -> None:
    image = np.zeros((4, 6, 3), dtype=np.uint8)  # black: I2 = I3 = 0, not skin
    image[:2, :2] = SKIN_BGR  # cell (0, 0): skin
    # Cell (1, 2): red ± 10 column by column (I2 ± 5), so only the mean is skin.
    image[2:, 4:] = [[(95, 135, 190), (95, 135, 210)]] * 2
    model = _one_class((52.5, -6.25))
    cells = candidate_cells(cell_chroma(image, cell_size=2), model)
    np.testing.assert_array_equal(cells, [[True, False, False], [False, False, True]])
    # A partial last column of cells is ignored: 7 columns still make 3 cells.
    assert candidate_cells(cell_chroma(np.zeros((4, 7, 3), np.uint8), cell_size=2), model).shape == (2, 3)


def test_merge_cells_through_the_adjacency_graph() -> None:
    candidates = np.array(
        [
            [1, 1, 0, 0, 0],
            [0, 0, 1, 0, 0],  # touches the first group diagonally: same region (8-connected)
            [0, 0, 0, 0, 1],
            [1, 0, 0, 0, 1],
        ],
        dtype=bool,
    )
    labels, count = merge_cells(candidates)
    assert count == 3
    assert labels[0, 0] == labels[0, 1] == labels[1, 2] != 0
    assert labels[2, 4] == labels[3, 4] not in (0, labels[0, 0])
    labels, count = merge_cells(candidates, min_region_cells=2)  # the single cell at (3, 0) goes
    assert count == 2 and labels[3, 0] == 0


def test_merge_cells_keeps_apart_neighbours_of_different_colour() -> None:
    candidates = np.ones((2, 4), dtype=bool)
    chroma = np.zeros((2, 4, 2))
    chroma[:, 2:, 0] = 12.0  # the right half of another shade; within 2 of its neighbours
    chroma[1, :2, 1] = 2.0
    labels, count = merge_cells(candidates, chroma=chroma, max_distance=10.0)
    assert count == 2
    assert labels[0, 0] == labels[0, 1] == labels[1, 0] == labels[1, 1] != labels[0, 2]
    assert labels[0, 2] == labels[0, 3] == labels[1, 2] == labels[1, 3] != 0
    assert merge_cells(candidates, chroma=chroma, max_distance=12.5)[1] == 1
    assert merge_cells(candidates, chroma=chroma)[1] == 1  # no distance: the paper's adjacency
    tiny = np.zeros((5, 5, 3), np.uint8)  # smaller than a cell: no cell, no region
    assert not segment_skin(tiny, default_skin_model(), SkinParameters(merge_distance=10.0)).any()


def test_a_waving_hand_is_its_own_skin_region_beside_a_skin_coloured_square() -> None:
    """people_crossing: the waving hand touches a flat skin-coloured square of another shade.
    Merged with it, their cluster is too spread for a class, and the hand is only the split
    part of a mixed cluster (128) on most frames; kept apart by colour, it is skin (255)."""
    frames = list(read_frames(REPO / 'bags' / 'people_crossing'))[:60]
    model = default_skin_model()

    def frames_with_the_hand_skin(parameters: SkinParameters) -> int:
        count = 0
        for frame in frames:
            x, y, w, h = (int(v) for v in frame.ground_truths['person_1/hand'])
            labels = segment_skin(message_to_bgr8(frame.message), model, parameters)
            count += bool((labels[y : y + h, x : x + w] == 255).mean() > 0.3)
        return count

    assert frames_with_the_hand_skin(SkinParameters()) < 30
    assert frames_with_the_hand_skin(SkinParameters(merge_distance=10.0)) > 40


def test_hysteresis_regions_grow_from_seeds_by_hand() -> None:
    # One class at I2 = 52.5, I3 = -6.25 with unit covariance, match distance 1: a pixel is a
    # seed within 1 of it, and joins a region within 2.5.
    model = _one_class((52.5, -6.25))
    image = np.zeros((3, 6, 3), dtype=np.uint8)  # black: distance 52.9, nothing
    image[1, 1] = SKIN_BGR  # distance 0: a seed
    image[1, 2] = (95, 135, 204)  # R + 4: I2 + 2, I3 - 1 -> distance sqrt(5) = 2.24: grows
    image[0, 3] = (95, 135, 204)  # touches (1, 2) diagonally: grows too
    image[2, 5] = (95, 135, 204)  # as close, but no seed in its region: dropped
    image[1, 4] = (95, 135, 206)  # R + 6: I2 + 3, I3 - 1.5 -> distance 3.35: beyond 2.5
    labels, count = hysteresis_regions(image, model, seed_scale=1.0, grow_scale=2.5)
    expected = np.zeros((3, 6), dtype=np.int32)
    expected[1, 1] = expected[1, 2] = expected[0, 3] = 1
    assert count == 1
    np.testing.assert_array_equal(labels, expected)
    # Every 8-bit colour reads its distance from the table exactly as the classes give it.
    colours = np.random.default_rng(0).integers(0, 256, size=(5000, 3)).astype(np.uint8)
    b, g, r = (colours[:, k].astype(int) for k in range(3))
    table = model.distance_table[r - b + 255, 2 * g - r - b + 510]
    np.testing.assert_allclose(table, model.distance(ohta(colours)[:, 1:]), rtol=1e-5)


def test_pixel_regions_find_a_face_smaller_than_two_cells() -> None:
    """A 10 x 10 pixel patch of skin on a wall: the 8-pixel cells it straddles are mostly wall,
    so the paper's phase 1 finds no candidate; the pixels find it whole."""
    image = np.zeros((64, 64, 3), dtype=np.uint8)
    image[:] = (200, 80, 40)
    image[27:37, 27:37] = SKIN_BGR
    cells = segment_skin(image, default_skin_model(), SkinParameters(regions='cells')) > 0
    pixels = segment_skin(image, default_skin_model(), SkinParameters(regions='pixels')) > 0
    assert not cells.any()
    assert pixels[27:37, 27:37].all() and np.count_nonzero(pixels) == 100
    with pytest.raises(ValueError, match='regions'):
        SkinParameters(regions='blobs').validate()
    with pytest.raises(ValueError, match='seed_scale'):
        SkinParameters(seed_scale=3.0, grow_scale=2.0).validate()


def test_histogram_modes_by_hand() -> None:
    # Peaks at bins 2 (20) and 7 (10); each mode runs down its slopes to 10 % of its peak.
    modes = histogram_modes(np.array([0, 10, 20, 10, 0, 0, 5, 10, 5, 0]), smoothing=0)
    np.testing.assert_array_equal(modes, [3, 0, 0, 0, 3, 3, 1, 1, 1, 3])
    # A valley stops a mode where the histogram rises again: bin 3 starts the second mode.
    np.testing.assert_array_equal(histogram_modes(np.array([0, 10, 4, 8, 0]), smoothing=0), [3, 0, 0, 1, 3])
    # A peak below peak_fraction of the highest is not principal.
    modes = histogram_modes(np.array([0, 100, 0, 5, 0]), smoothing=0, peak_fraction=0.1)
    np.testing.assert_array_equal(modes, [3, 0, 3, 3, 3])


def _picture() -> tuple[np.ndarray, np.ndarray]:
    """Blue wall, a flat skin square, and a noisy square whose mean colour is skin."""
    rng = np.random.default_rng(0)
    image = np.zeros((120, 160, 3), dtype=np.uint8)
    image[:] = (200, 80, 40)
    image[16:64, 16:64] = SKIN_BGR
    noisy = np.array(SKIN_BGR, dtype=float) + rng.uniform(-60, 60, size=(48, 48, 3))
    image[56:104, 96:144] = np.clip(noisy, 0, 255).astype(np.uint8)
    truth = np.zeros(image.shape[:2], dtype=bool)
    truth[16:64, 16:64] = True
    return image, truth


def test_segmentation_keeps_flat_skin_and_drops_a_textured_region() -> None:
    image, truth = _picture()
    mask = segment_skin(image, default_skin_model()) > 0
    assert mask[truth].mean() > 0.95  # the skin square, to its borders (the grown cells)
    # The textured square's cells average to skin, but its variance is no skin class's.
    assert mask[56:104, 96:144].mean() < 0.05
    assert mask[~truth].mean() < 0.01


def test_colour_blur_labels_skin_under_a_noisy_camera(tmp_path) -> None:
    """Per-pixel colour noise (σ 20 a channel) scatters a skin square's pixels out of its modes,
    and its cluster's variance out of its class's: no label. Smoothed first (σ 1 pixel), the
    square is labelled to within its border, and nothing else is; ``skin --colour-blur`` too."""
    image = np.full((120, 160, 3), (60, 160, 60), dtype=np.uint8)
    noisy = np.array(SKIN_BGR, dtype=float) + np.random.default_rng(0).normal(0.0, 20.0, (48, 48, 3))
    image[16:64, 16:64] = np.clip(noisy, 0, 255).astype(np.uint8)
    model = default_skin_model()
    assert not (segment_skin(image, model) > 0).any()
    mask = segment_skin(image, model, SkinParameters(colour_blur=1.0)) > 0
    assert mask[16:64, 16:64].mean() > 0.9
    assert np.count_nonzero(mask) < 1.1 * 48 * 48
    assert SkinParameters(colour_blur=2.0).scaled(0.5).colour_blur == 1.0
    with pytest.raises(ValueError, match='colour_blur'):
        SkinParameters(colour_blur=-1.0).validate()
    (tmp_path / 'frames').mkdir()
    cv2.imwrite(str(tmp_path / 'frames' / 'noisy.png'), image)
    for blur, labelled in (('0', False), ('1', True)):
        assert main(['skin', str(tmp_path / 'frames'), '--out', str(tmp_path / blur), '--colour-blur', blur]) == 0
        assert cv2.imread(str(tmp_path / blur / 'noisy.png'), cv2.IMREAD_GRAYSCALE).any() == labelled


def test_skin_in_a_dim_frame_is_labelled_once_the_exposure_is_normalised() -> None:
    """At 0.3 of its brightness a skin square's (I2, I3) = (16, -2) falls short of every skin
    class: no label. Brightened first (the frame's brightest pixels back to white), it is
    labelled, and nothing else is."""
    image = np.full((120, 160, 3), (60, 160, 60), dtype=np.uint8)
    image[16:64, 16:64] = SKIN_BGR
    dimmed = np.rint(image * 0.3).astype(np.uint8)
    model = default_skin_model()
    assert segment_skin(image, model)[16:64, 16:64].all()
    assert not segment_skin(dimmed, model, SkinParameters(max_exposure_gain=1.0)).any()
    mask = segment_skin(dimmed, model) > 0
    assert mask[16:64, 16:64].mean() > 0.9 and np.count_nonzero(mask) <= 48 * 48
    with pytest.raises(ValueError, match='max_exposure_gain'):
        SkinParameters(max_exposure_gain=0.5).validate()


def test_segmentation_recall_on_the_synthetic_hand_scene() -> None:
    frames = list(render_scene(SCENES['hand_wave']))[::30]
    model = default_skin_model()
    masks = [segment_skin(f.image, model) > 0 for f in frames]
    hits = sum(np.count_nonzero(m & f.skin) for m, f in zip(masks, frames, strict=True))
    skin = sum(np.count_nonzero(f.skin) for f in frames)
    labelled = sum(np.count_nonzero(m) for m in masks)
    # The face and the hand are found; the scene's wooden furniture is skin-coloured by design,
    # so precision is low (shape, not colour, tells the hand apart).
    print(f'hand_wave skin labels: recall {hits / skin:.3f}, precision {hits / labelled:.3f}')
    assert hits / skin > 0.85


def test_adaptation_moves_towards_the_target_within_bounds() -> None:
    prior = _one_class((50.0, -5.0), variance=4.0, match=3.0)
    # The colours as given (no exposure normalisation): the values below are computed from them.
    segmenter = SkinSegmenter(prior, SkinParameters(max_exposure_gain=1.0), adaptation_rate=0.5, max_drift=1.5)
    image = np.zeros((20, 20, 3), dtype=np.uint8)
    image[:] = (90, 130, 198)  # I2 = (198 - 90) / 2 = 54, I3 = (260 - 198 - 90) / 4 = -7
    region = np.ones((20, 20), dtype=np.uint8)
    assert segmenter.adapt(image, region, region)
    # Halfway, (52, -6): Mahalanobis sqrt((2² + 1²) / 4) = 1.12 from the prior, within max_drift.
    np.testing.assert_allclose(segmenter.model.classes[0].mean, [52.0, -6.0], atol=1e-4)
    image[:] = (40, 130, 200)  # I2 = 80: far from every prior class, refused
    assert not segmenter.adapt(image, region, region)
    assert not segmenter.adapt(image, region, np.zeros_like(region))  # no skin pixels: nothing to learn
    segmenter.reset()
    assert segmenter.model is prior
    with pytest.raises(ValueError, match='adaptation_rate'):
        SkinSegmenter(prior, adaptation_rate=2.0)


def test_model_file_round_trip_and_errors(tmp_path) -> None:
    model = default_skin_model()
    assert len(model.classes) >= 2 and model.notes['non_skin_accepted'] < 0.01
    again = SkinModel.from_json(model.to_json())
    np.testing.assert_allclose(again.classes[0].covariance, model.classes[0].covariance, atol=1e-3)
    bad = tmp_path / 'bad.json'
    bad.write_text(json.dumps({'match_distance': 2, 'classes': [{'mean': [0, 0], 'covariance': [[1, 2], [2, 1]]}]}))
    with pytest.raises(ValueError, match='positive definite'):
        SkinModel.load(bad)
    with pytest.raises(ValueError, match='cannot load skin model'):
        SkinModel.load(tmp_path / 'missing.json')


def test_training_separates_skin_from_other_colours() -> None:
    rng = np.random.default_rng(1)
    skin = np.clip(np.array(SKIN_BGR) + rng.normal(0, 6, size=(500, 3)), 0, 255)
    other = rng.uniform(0, 255, size=(2000, 3))
    model = train_skin_model(
        np.vstack([skin, other]), np.r_[np.ones(500, bool), np.zeros(2000, bool)], num_classes=2, skin_coverage=0.9
    )
    inside = model.distance(ohta(skin.astype(np.float32))[:, 1:]) <= model.match_distance
    assert inside.mean() == pytest.approx(0.9, abs=0.01)
    assert model.notes['non_skin_accepted'] < 0.05 and model.notes['skin_samples'] == 500
    with pytest.raises(ValueError, match='skin samples'):
        train_skin_model(skin[:5], np.ones(5, bool))


def test_skin_sample_file_errors(tmp_path) -> None:
    path = tmp_path / 'samples.txt'
    path.write_text('1 2 3 1\n4 5 6 3\n')
    with pytest.raises(ValueError, match='class must be 1'):
        read_skin_samples(path)
    path.write_text('1 2 3\n')
    with pytest.raises(ValueError, match='4 columns'):
        read_skin_samples(path)


@pytest.mark.skipif(not SKIN_SAMPLES.exists(), reason='skin samples (../shared/data/skin) not present')
def test_the_shipped_model_is_what_train_skin_makes(tmp_path) -> None:
    out = tmp_path / 'model.json'
    assert main(['train-skin', str(SKIN_SAMPLES), '--out', str(out)]) == 0
    trained, shipped = SkinModel.load(out), default_skin_model()
    assert trained.match_distance == pytest.approx(shipped.match_distance, rel=1e-6)
    for a, b in zip(trained.classes, shipped.classes, strict=True):
        np.testing.assert_allclose(a.mean, b.mean, atol=1e-3)
    assert trained.notes == shipped.notes


def test_the_skin_command_writes_a_mask_per_image_and_counts_the_unreadable(tmp_path, capsys) -> None:
    """`human_tracker skin --general`: one PNG per image, same stem, 255 = skin, as the skin stage
    labels it with the general classes."""
    frames = list(render_scene(SCENES['hand_wave']))[:2]
    folder = tmp_path / 'in'
    folder.mkdir()
    for k, frame in enumerate(frames):
        cv2.imwrite(str(folder / f'frame_{k}.png'), frame.image)
    assert main(['skin', str(folder), '--out', str(tmp_path / 'out'), '--working-width', '0', '--general']) == 0
    for k, frame in enumerate(frames):
        mask = cv2.imread(str(tmp_path / 'out' / f'frame_{k}.png'), cv2.IMREAD_GRAYSCALE)
        np.testing.assert_array_equal(mask > 0, segment_skin(frame.image, default_skin_model()) > 0)
        assert set(np.unique(mask)) == {0, 255}
    # At the working width the labels come back at the frame's size.
    assert main(['skin', str(folder), '--out', str(tmp_path / 'small'), '--working-width', '160']) == 0
    assert cv2.imread(str(tmp_path / 'small' / 'frame_0.png')).shape[:2] == frames[0].image.shape[:2]
    assert (
        main(
            [
                'skin',
                str(folder),
                '--out',
                str(tmp_path / 'pixels'),
                '--working-width',
                '0',
                '--regions',
                'pixels',
                '--general',
            ]
        )
        == 0
    )
    pixels = SkinParameters(regions='pixels')
    mask = cv2.imread(str(tmp_path / 'pixels' / 'frame_0.png'), cv2.IMREAD_GRAYSCALE)
    np.testing.assert_array_equal(mask, segment_skin(frames[0].image, default_skin_model(), pixels))
    (folder / 'broken.png').write_bytes(b'not an image')
    assert main(['skin', str(folder), '--out', str(tmp_path / 'again')]) == 1
    assert '1 unreadable images: broken' in capsys.readouterr().err
    assert main(['skin', str(tmp_path / 'nothing'), '--out', str(tmp_path / 'x')]) == 2


def test_two_means_separates_a_mixed_cluster() -> None:
    # One cluster (0) of two colours, 30 px of B, G, R = 40, 80, 120 (I2 = 40, I3 = 0) and 10
    # px of 120, 80, 40 (I2 = -40, I3 = 0); cluster 1 is not mixed and -1 is no cluster.
    image = np.zeros((4, 12, 3), np.uint8)
    clusters = np.full((4, 12), -1, np.int64)
    image[:3, :10], clusters[:3, :10] = (40, 80, 120), 0
    image[3, :10], clusters[3, :10] = (120, 80, 40), 0
    clusters[:, 10] = 1
    rows, cols, part, n, sums, squares = two_means(image, clusters, np.array([True, False]), 5)
    assert len(rows) == 40 and set(zip(rows.tolist(), cols.tolist(), strict=True)) == {
        (v, u) for v in range(4) for u in range(10)
    }
    # Two parts of cluster 0 (parts 0 and 1), one colour each; no part of cluster 1.
    first = part[rows < 3][0]
    assert set(part[rows < 3].tolist()) == {first} and set(part[rows == 3].tolist()) == {1 - first}
    np.testing.assert_allclose(n, [30, 10, 0, 0] if first == 0 else [10, 30, 0, 0])
    np.testing.assert_allclose(sums[first], [30 * 40.0, 0.0])
    np.testing.assert_allclose(squares[1 - first], [10 * 1600.0, 0.0])


def test_skin_mixed_with_clothes_of_a_near_colour_is_split_from_them() -> None:
    # A patch whose pixels mix skin with a khaki jacket's near colour, evenly over its cells:
    # I2 runs over 48 quantiles of N(36, 12²), shuffled along each row. Every cell's mean
    # (36) is within the class's (42, variance 16), so the patch is one region, and its
    # histograms one mode: one cluster, too spread for the class (variance over 6 x 16),
    # refused whole. Split in two, the upper part (mean about 46) is the class's; the
    # lower one (about 27: 3.7 class deviations, 3 allowed) is not.
    model = _one_class((42.0, 0.0), variance=16.0, match=2.0)
    i2 = 36.0 + 12.0 * np.sqrt(2.0) * erfinv(2.0 * (np.arange(48) + 0.5) / 48 - 1.0)
    rng = np.random.default_rng(0)
    values = np.stack([rng.permutation(i2) for _ in range(48)])
    image = np.full((64, 96, 3), 60, np.uint8)
    # B, G, R with I1 = 120, I2 = (R - B) / 2, I3 = 0: R = 120 + I2, G = 120, B = 120 - I2.
    patch = np.stack([120 - values, np.full_like(values, 120.0), 120 + values], axis=-1)
    image[8:56, 24:72] = patch.round().astype(np.uint8)
    given = SkinParameters(max_exposure_gain=1.0)  # the colours as given, as computed above
    assert np.count_nonzero(segment_skin(image, model, replace(given, split_mixed=False))) == 0
    labels = segment_skin(image, model, given)
    assert set(np.unique(labels)) == {0, MIXED_SKIN}
    chroma = ohta(image[8:56, 24:72])[..., 1]
    labelled = labels[8:56, 24:72] > 0
    assert labelled[(chroma > 40) & (chroma < 55)].all() and not labelled[chroma < 32].any()
    assert np.count_nonzero(labels) == np.count_nonzero(labelled)  # nothing off the patch


@pytest.mark.skipif(not HGR.is_dir(), reason='../shared/data/skin/hgr is absent')
def test_skin_labels_on_real_photos_with_pixel_masks() -> None:
    """HGR's 178 photos of hands: the figures `make bench` reports (pooled and per photo)."""
    scores = labelled_photo_scores(HGR)
    print(f'HGR skin labels: {scores}')
    assert scores['photos'] == 178
    assert scores['precision'] >= 0.85 and scores['recall'] >= 0.85
    assert scores['mean_photo_f1'] >= 0.8  # 0.829 measured: a few photos of hands on skin-coloured walls are poor
    # Seeds grown by hysteresis: the skin the cells miss, at some precision (0.95 / 0.75
    # measured: brightened, HGR's hands clip, and shirts of a near colour join them).
    pixels = labelled_photo_scores(HGR, parameters=SkinParameters(regions='pixels'))
    print(f'HGR skin labels, regions: pixels: {pixels}')
    assert pixels['recall'] >= 0.9 and pixels['precision'] >= 0.7
