"""The method, free of ROS: a frame in, every target's outcome out.

Its layers, each importing only those below it:

- :mod:`~human_tracker.vision.frame_pipeline`: the one frame path every layout runs;
- :mod:`~human_tracker.vision.people`: people, a head and hands each, with ids;
- :mod:`~human_tracker.vision.track`: one target's track, its state and its step;
- :mod:`~human_tracker.vision.faces`: faces, the evidence that a head is a head;
- :mod:`~human_tracker.vision.cues`: what a frame says (motion, skin, edges, appearance);
- :mod:`~human_tracker.vision.geometry`: boxes, the camera, depth;
- :mod:`~human_tracker.vision.filter`: the paper's contour filter (splines, AR(2), eqs. 1-4);

and :mod:`~human_tracker.vision.checks`, the range checks of every parameter class.
"""
