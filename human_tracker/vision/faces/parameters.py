"""Where faces come in to one target's tracking: proposals, faces to keep off, when the detector runs."""

from __future__ import annotations

from dataclasses import dataclass

from human_tracker.vision.checks import check_choices, check_within, parameter

__all__ = ['PROPOSALS', 'FaceParameters']

PROPOSALS = ('faces', 'skin', 'off')


@dataclass(frozen=True)
class FaceParameters:
    """Where faces come in: proposals, faces to keep off, and when the detector runs.

    Attributes:
        proposals: ``faces`` (face detections draw particles and start or restart the
            track, :mod:`~human_tracker.vision.filter.proposals`; needs dlib), ``skin`` (the
            moments of the skin regions that hypotheses come from draw particles, spread as
            widely as a hypothesis's cloud: for a hand) or ``off``.
        avoid_faces: For a hand: faces the detector finds (every ``detect_every`` frames,
            around the last one found) are not the target. A contour on the face found last
            is a weak frame, and the face is cut from the skin regions that hypotheses come
            from. Needs dlib.
        detect_every: Run the detector on every this many frames (around the predicted face
            while tracking, on the whole working frame while searching).
        patient_every: Once :data:`~human_tracker.vision.faces.schedule.PATIENT_SEARCHES` runs
            in a row found no face, let at least this many frames pass between runs.
        face_search_reach: While the head is tracked the detector looks within this many
            face sizes of the predicted face; a run's time goes with its square
            (docs/decisions/face-search-reach.md).
        detector_thread: Run the detector in its own thread: a run on frame k goes on while
            the tracker finishes frame k and the next frame arrives, and its faces are used on
            frame k + 1, which waits for them (a replay gives the same track on any machine).
            False: on the frame it ran on, at that frame's cost.
        detector_wait_interval: With ``detector_thread``, a frame stamped more than this many
            seconds after the one before waits for its own detector run and uses its faces
            itself: faces a frame late are carried by the filter's predicted motion, which a
            person turning back outruns when frames are far apart (docs/decisions/slow-camera.md).
            Frames without stamps never wait.
        box_search_reach: With ``faces`` proposals, between the faces that anchor it a head's
            reported box is searched for by its grey-level look this many box widths to every
            side of where the contour places it (:mod:`~human_tracker.vision.faces.box_look`); 0: the
            box is where the contour places it.
        box_min_match: The least normalised cross-correlation, in [-1, 1], of the box's look
            that moves it.
        box_look_rate: The share of a matched box's grey levels blended into the look, so that
            it follows a face that changes between faces found (a cap put on); 0: the look
            learnt on the faces alone.
    """

    proposals: str = parameter(
        'faces',
        'faces (face detections draw particles, start and restart; needs dlib), skin (skin regions draw particles: a'
        ' hand) or off.',
        runtime=False,
    )
    avoid_faces: bool = parameter(
        False, 'A hand: a contour on a detected face is weak; no hypothesis there.', runtime=False
    )
    detect_every: int = parameter(1, 'Run the face detector on every this many frames.', low=1, high=100000)
    patient_every: int = parameter(
        8, 'Frames between face detector runs once several found no face.', low=1, high=100000
    )
    face_search_reach: float = parameter(
        2.0, 'Face sizes around the predicted face the detector looks within.', low=0.5, high=10.0
    )
    detector_thread: bool = parameter(
        True, 'Face detector in its own thread; its faces serve the next frame.', runtime=False
    )
    detector_wait_interval: float = parameter(
        0.05,
        'Seconds between frames above which a frame waits for its own face detector run (a slow camera).',
        low=0.0,
        high=3600.0,
    )
    box_search_reach: float = parameter(
        0.35,
        "Box widths around the contour's place a head's box is searched for by its look between faces; 0: off.",
        low=0.0,
        high=2.0,
    )
    box_min_match: float = parameter(
        0.6, "Least normalised cross-correlation of the box's look that moves it.", low=-1.0, high=1.0
    )
    box_look_rate: float = parameter(
        0.1, "Share of a matched box's grey levels blended into its look.", low=0.0, high=1.0
    )

    @property
    def wants_faces(self) -> bool:
        """Whether the track runs a face detector: faces as proposals, or faces to avoid."""
        return self.proposals == 'faces' or self.avoid_faces

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        check_choices(self, proposals=PROPOSALS)
        if self.avoid_faces and self.proposals == 'faces':
            raise ValueError('avoid_faces is for a hand: with proposals: faces, faces are the target')
        check_within(
            self,
            detect_every=(self.detect_every >= 1, '>= 1'),
            patient_every=(self.patient_every >= 1, '>= 1'),
            face_search_reach=(self.face_search_reach > 0.0, '> 0'),
            detector_wait_interval=(self.detector_wait_interval >= 0.0, '>= 0 (s)'),
            box_search_reach=(0.0 <= self.box_search_reach <= 2.0, 'in [0, 2] (box widths)'),
            box_min_match=(-1.0 <= self.box_min_match <= 1.0, 'in [-1, 1]'),
            box_look_rate=(0.0 <= self.box_look_rate <= 1.0, 'in [0, 1]'),
        )
