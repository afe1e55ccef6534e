"""One face detector for every target of a frame (vision/faces/finder.py)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DLIB_MISSING

from human_tracker.vision.faces.detector import Detection, near_region
from human_tracker.vision.faces.finder import (
    FINE_WHOLE_FRAME_ZOOM,
    WHOLE_FRAME_ZOOM,
    FaceFinder,
    Search,
    plan_runs,
)
from human_tracker.vision.faces.parameters import FaceParameters
from human_tracker.vision.people.persons import PersonTracker

FRAME = (0, 0, 320, 240)


class _Detector:
    """A face detector that finds the faces it is given wherever it looks, and counts its runs."""

    def __init__(self, faces: list[tuple[float, float, float, float]]) -> None:
        self.faces = [Detection(box, 1.0) for box in faces]
        self.runs: list[tuple[str, object]] = []

    def detect(self, image: np.ndarray, upsample: int = 1) -> list[Detection]:
        self.runs.append(('frame', upsample))
        return list(self.faces)

    def detect_near(self, image: np.ndarray, box: tuple[float, ...], reach: float = 2.0) -> list[Detection]:
        self.runs.append(('near', box))
        rectangle, _ = near_region(image.shape, box, reach)
        return [face for face in self.faces if Search(rectangle, 1.0).holds(face)]

    def detect_region(self, image: np.ndarray, rectangle: tuple[int, ...], zoom: float) -> list[Detection]:
        self.runs.append(('region', (rectangle, zoom)))
        return [face for face in self.faces if Search(rectangle, zoom).holds(face)]  # type: ignore[arg-type]


def test_searches_merge_only_when_that_scans_fewer_pixels() -> None:
    """Two crops around one face at one zoom are one run over both; crops far apart, or at
    zooms more than a pyramid step apart, stay two; a crop at the whole frame's zoom or less is
    answered by the whole-frame run, a finer one not."""
    a, b = Search((100, 50, 180, 130), 1.5), Search((110, 60, 190, 140), 1.5)
    (run, members), *rest = plan_runs([a, b], FRAME)
    assert not rest and members == [0, 1] and run == Search((100, 50, 190, 140), 1.5)
    assert run.cost < a.cost + b.cost
    far = Search((0, 0, 60, 60), 1.5)
    assert len(plan_runs([a, far], FRAME)) == 2
    # More than a step of the detector's pyramid apart: the larger zoom would find smaller faces.
    assert len(plan_runs([a, Search((110, 60, 190, 140), 1.5 * 1.25)], FRAME)) == 2
    whole = Search(FRAME, WHOLE_FRAME_ZOOM)
    assert plan_runs([a, whole], FRAME) == [(whole, [0, 1])]
    fine = Search((100, 50, 140, 90), 3.0)  # a face too small for the whole-frame search
    assert len(plan_runs([fine, whole], FRAME)) == 2
    # The fine whole-frame search runs alone: it answers no other search, finer or not.
    alone = Search(FRAME, FINE_WHOLE_FRAME_ZOOM, shared=False)
    assert len(plan_runs([a, fine, alone], FRAME)) == 3 and not alone.contains(a)


@pytest.mark.parametrize('thread', [True, False])
def test_the_searches_of_a_frame_run_once_and_each_gets_its_own_faces(thread: bool) -> None:
    """Held until submitted, a head's and a hand's searches around the same face make one
    run; each gets the faces whose centre lies in its own rectangle. Alone, a search runs as it
    did before the finder (detect_near); on a new frame nothing is answered from the last."""
    face, other = (140.0, 80.0, 40.0, 40.0), (20.0, 20.0, 40.0, 40.0)
    detector = _Detector([face, other])
    finder = FaceFinder(detector, thread=thread)  # type: ignore[arg-type]
    image = np.zeros((240, 320), np.uint8)
    finder.hold = True
    head = finder.near(image, (138.0, 78.0, 40.0, 40.0), 2.0)
    hand = finder.near(image, (142.0, 84.0, 40.0, 40.0), 2.0)
    assert detector.runs == []  # held
    finder.submit()
    assert [face.box for face in head.result()] == [face] and [face.box for face in hand.result()] == [face]
    assert [kind for kind, _ in detector.runs] == ['region']
    # A search inside a run made on this frame is answered from it.
    finder.hold = False
    again = finder.near(image, (140.0, 80.0, 40.0, 40.0), 1.0)
    assert [face.box for face in again.result()] == [face] and len(detector.runs) == 1
    finder.new_frame()
    alone = finder.near(image, (140.0, 80.0, 40.0, 40.0), 2.0)
    assert [face.box for face in alone.result()] == [face]
    assert detector.runs[-1] == ('near', (140.0, 80.0, 40.0, 40.0))
    finder.new_frame()
    everywhere = finder.whole(image)
    assert len(everywhere.result()) == 2 and detector.runs[-1] == ('frame', 1)
    finder.new_frame()
    finer = finder.whole(image, FINE_WHOLE_FRAME_ZOOM)
    assert len(finer.result()) == 2 and detector.runs[-1] == ('region', (FRAME, FINE_WHOLE_FRAME_ZOOM))


def test_every_target_of_a_person_tracker_searches_on_one_detector() -> None:
    """Two people with a head and two hands each: six targets, one detector and one thread."""
    people = PersonTracker(('head', 'hand', 'hand'), max_people=2)
    assert people.face_finder is not None, DLIB_MISSING
    assert all(tracker.faces.finder is people.face_finder for tracker in people.trackers)
    assert len(people.trackers) == 6


def test_a_later_persons_head_also_looks_for_small_faces() -> None:
    """A later person is taken up only on a face: until their head finds one, every
    ``patient_every``-th whole-frame search also looks for faces too small for it, in a run
    of its own at the fine zoom; the faces of the usual run stay as they were. The first
    person's head never looks so."""
    people = PersonTracker(('head', 'hand'), max_people=2)
    assert not people.slot('head').tracker.faces.small_faces
    assert not people.slot('person_2/hand').tracker.faces.small_faces
    schedule = people.slot('person_2/head').tracker.faces
    assert schedule.small_faces
    small, large = (20.0, 20.0, 24.0, 24.0), (140.0, 80.0, 60.0, 60.0)
    detector = _Detector([small, large])
    usual = detector.detect
    # The usual whole-frame run misses the small face.
    detector.detect = lambda image, upsample=1: [f for f in usual(image, upsample) if f.box[2] > 40]
    schedule.finder = FaceFinder(detector, thread=False)  # type: ignore[arg-type]
    parameters = FaceParameters()
    image = np.zeros((240, 320), np.uint8)
    every = parameters.patient_every
    finder = schedule.finder

    def frame() -> list[Detection] | None:
        finder.new_frame()
        return schedule.detect(image, True, parameters, lambda misses: None, lambda faces: faces)

    found = [frame() for _ in range(every)]
    assert [[face.box for face in faces] for faces in found] == [[large]] * (every - 1) + [[large, small]]
    assert detector.runs[-2:] == [('frame', 1), ('region', (FRAME, FINE_WHOLE_FRAME_ZOOM))]
    schedule.last_face = large  # its own face, found: the usual search only
    for _ in range(every):
        frame()
    assert detector.runs[-every:] == [('frame', 1)] * every
