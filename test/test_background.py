"""Background subtraction after Donohoe et al. with the paper's selective update (§2.4.1)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from conftest import BAGS, REAL_DATA, REPO

from human_tracker.io.bags import read_frames
from human_tracker.ros.image_conversion import message_to_bgr8, to_mono8
from human_tracker.vision.cues.background import BackgroundModel, BackgroundParameters, background_decision

NO_MORPHOLOGY = {'opening_radius': 0, 'closing_radius': 0}


def test_decision_rule_hand_computed() -> None:
    # σ² = 25, n = 256, λ = 1: background iff (i - m)² < 2·25·(ln 256 - ½ ln(2π·25)) = 150.85,
    # i.e. |i - m| <= 12 (12² = 144 < 150.85 < 169 = 13²).
    mean = np.full(4, 100.0, dtype=np.float32)
    variance = np.full(4, 25.0, dtype=np.float32)
    intensity = np.array([100.0, 112.0, 113.0, 88.0])
    assert background_decision(intensity, mean, variance).tolist() == [True, True, False, True]
    # λ = 10 is stricter: (i - m)² < 50·(ln 25.6 - 2.5283) = 35.7, |i - m| <= 5.
    assert background_decision(np.array([105.0, 106.0]), mean[:2], variance[:2], threshold=10.0).tolist() == [
        True,
        False,
    ]


def test_threshold_scales_with_sigma() -> None:
    # A larger σ accepts larger differences as background.
    mean = np.full(2, 100.0, dtype=np.float32)
    assert not background_decision(np.array([120.0]), mean[:1], np.array([25.0]))[0]
    assert background_decision(np.array([120.0]), mean[:1], np.array([100.0]))[0]


def test_selective_update_hand_computed() -> None:
    model = BackgroundModel(BackgroundParameters(learning_rate=0.1, initial_variance=25.0, **NO_MORPHOLOGY))
    first = np.full((1, 2), 100, dtype=np.uint8)
    assert model.apply(first).tolist() == [[0, 0]]  # the first frame is the reference
    mask = model.apply(np.array([[104, 200]], dtype=np.uint8))
    assert mask.tolist() == [[0, 255]]
    # Background pixel: m = 0.1·104 + 0.9·100 = 100.4; σ² = 0.1·4² + 0.9·25 = 24.1.
    assert model.mean[0, 0] == pytest.approx(100.4)
    assert model.variance[0, 0] == pytest.approx(24.1)
    # Target pixel: neither m nor σ² moves (the paper's modification).
    assert model.mean[0, 1] == pytest.approx(100.0)
    assert model.variance[0, 1] == pytest.approx(25.0)


def test_variance_is_bounded_so_the_test_cannot_degenerate() -> None:
    model = BackgroundModel(
        BackgroundParameters(learning_rate=0.5, min_variance=4.0, max_variance=400.0, **NO_MORPHOLOGY)
    )
    still = np.full((2, 2), 80, dtype=np.uint8)
    for _ in range(100):
        model.apply(still)
    assert model.variance.min() == pytest.approx(4.0)  # would have decayed to 0
    # With σ² = 4: (i - m)² < 8·(ln 256 - ½ ln(8π)) = 31.46: 5 grey levels is noise, 6 is a target.
    assert model.apply(np.array([[85, 86], [80, 80]], dtype=np.uint8)).tolist() == [[0, 255], [0, 0]]
    with pytest.raises(ValueError, match='min_variance'):
        BackgroundParameters(min_variance=0.0).validate()


def test_morphology_removes_isolated_pixels_and_reset_restarts() -> None:
    model = BackgroundModel(BackgroundParameters(opening_radius=1, closing_radius=0))
    base = np.full((20, 20), 50, dtype=np.uint8)
    model.apply(base)
    frame = base.copy()
    frame[3, 3] = 250  # one speck
    frame[10:16, 10:16] = 250  # a blob
    mask = model.apply(frame)
    assert mask[3, 3] == 0 and mask[12, 12] == 255
    model.reset()
    assert model.apply(frame).max() == 0


def test_foreground_covers_the_person_on_the_stop_and_go_bag() -> None:
    """The person appears at frame 10 and stands still until 30, then stops again 75-105."""
    model = BackgroundModel()
    coverage, false_alarm = [], []
    for frame in read_frames(str(BAGS / 'head_stop_and_go')):
        mask = model.apply(to_mono8(message_to_bgr8(frame.message)))
        if frame.ground_truth is None:
            false_alarm.append(np.mean(mask > 0))
            continue
        x, y, w, h = (int(v) for v in frame.ground_truth)
        coverage.append(np.mean(mask[y : y + h, x : x + w] > 0))
        far = mask.copy()
        far[:, max(x - 2 * w, 0) : x + 3 * w] = 0  # away from the person's body
        false_alarm.append(np.mean(far > 0))
    print(
        f'head box covered {np.mean(coverage):.3f} (min {np.min(coverage):.3f}); '
        f'false alarms {np.mean(false_alarm):.4f}'
    )
    # The head ellipse fills π/4 = 0.79 of its box; a still person stays foreground because
    # only background pixels are learnt.
    assert np.mean(coverage) > 0.55 and np.min(coverage) > 0.35
    assert np.mean(false_alarm) < 0.01


VTEST = REAL_DATA / 'vtest' / 'vtest.avi'
OUT = REPO / 'out' / 'reports'


@pytest.mark.skipif(not VTEST.exists(), reason=f'{VTEST} not available')
def test_foreground_on_the_real_vtest_sequence() -> None:
    """Walking pedestrians, static camera: the foreground is the people and little else."""
    OUT.mkdir(parents=True, exist_ok=True)
    capture = cv2.VideoCapture(str(VTEST))
    model = BackgroundModel()
    fractions, blob_counts = [], []
    index = 0
    while True:
        ok, image = capture.read()
        if not ok:
            break
        mask = model.apply(to_mono8(image))
        if index >= 50:  # once the reference frame has settled
            fractions.append(np.mean(mask > 0))
            count, _, stats, _ = cv2.connectedComponentsWithStats(mask)
            blob_counts.append(int(np.sum(stats[1:, cv2.CC_STAT_AREA] >= 150)))
        if index == 300:
            shown = image.copy()
            shown[mask > 0] = (0.5 * shown[mask > 0] + (0, 0, 127)).astype(np.uint8)
            cv2.imwrite(str(OUT / 'vtest_foreground_300.png'), shown)
        index += 1
    fractions = np.array(fractions)
    print(
        f'vtest: {index} frames, foreground fraction mean {fractions.mean():.4f}, 95th percentile '
        f'{np.percentile(fractions, 95):.4f}; person-sized blobs per frame {np.mean(blob_counts):.1f}'
    )
    assert index > 700
    assert 0.003 < fractions.mean() < 0.08  # people are a few percent of the view
    assert np.mean(blob_counts) >= 2  # several walkers are segmented


def _flooding_scene(frames: int = 30) -> list[np.ndarray]:
    """A textured still scene with a square walking across; the exposure drops by a fifth at
    frame 10 (a camera's automatic exposure)."""
    rng = np.random.default_rng(3)
    scene = cv2.GaussianBlur(rng.integers(40, 220, (60, 80)).astype(np.uint8), (5, 5), 0)
    out = []
    for k in range(frames):
        frame = scene.copy()
        frame[20:35, 5 + 2 * k : 20 + 2 * k] = 250
        out.append((frame * (0.8 if k >= 10 else 1.0)).astype(np.uint8))
    return out


def test_a_flooded_model_starts_again_from_the_frame() -> None:
    """After an exposure jump every pixel differs from the reference; the paper's model
    (``flooded_frames`` 0) never learns them again (the mask stays flooded); by default
    the model starts again after five flooded masks and then finds the moving square alone."""
    paper = BackgroundModel(BackgroundParameters(flooded_frames=0))
    model = BackgroundModel()
    shares, paper_shares = [], []
    for frame in _flooding_scene():
        shares.append(np.mean(model.apply(frame) > 0))
        paper_shares.append(np.mean(paper.apply(frame) > 0))
    assert min(paper_shares[10:]) > 0.5  # flooded for good
    assert all(s > 0.5 for s in shares[10:15])  # the five flooded masks, returned as they are
    assert max(shares[17:]) < 0.15 and min(shares[17:]) > 0.02  # the square (4 % of the frame) and its ghost
    assert model.restarts == 1 and paper.restarts == 0
    with pytest.raises(ValueError, match='flooded_fraction'):
        BackgroundParameters(flooded_fraction=0.0).validate()


CAP_AND_BOOK = REAL_DATA / 'cap_and_book' / 'img'


@pytest.mark.skipif(not CAP_AND_BOOK.exists(), reason=f'{CAP_AND_BOOK} not available')
def test_the_mask_recovers_from_a_real_exposure_jump() -> None:
    """cap_and_book: the camera's exposure jumps at frame 369 (a book lifted before the lens).
    The paper's model calls most of every later frame foreground; restarted after five
    flooded masks, the model isolates the man again a few frames later."""
    paper = BackgroundModel(BackgroundParameters(flooded_frames=0))
    model = BackgroundModel()
    shares, paper_shares = [], []
    for path in sorted(CAP_AND_BOOK.iterdir()):
        frame = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)  # 320x240, the working width
        shares.append(np.mean(model.apply(frame) > 0))
        paper_shares.append(np.mean(paper.apply(frame) > 0))
    after = slice(380, None)
    print(
        f'frames over half foreground: {sum(s > 0.5 for s in shares)} (paper {sum(s > 0.5 for s in paper_shares)}); '
        f'median after 380 {np.median(shares[after]):.2f} (paper {np.median(paper_shares[after]):.2f})'
    )
    assert np.median(paper_shares[after]) > 0.6
    assert np.median(shares[after]) < 0.5 and sum(s > 0.5 for s in shares) < 60
