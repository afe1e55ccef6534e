"""Skin colour segmentation of §3.2 in Ohta's I1 I2 I3 colour space.

The segmentation has the paper's two phases:

1. **Regions.** ``regions: cells`` (the paper's): the image is divided into square cells;
   a cell whose mean chromaticity (I2, I3) falls inside one of the learnt skin classes is a
   candidate, and candidate cells are merged into regions through their adjacency graph
   (8-connected cells). ``regions: pixels`` (a departure, opt-in): each pixel's own (I2, I3)
   is compared with the classes; pixels well inside a class are seeds, and a region is the
   8-connected set of pixels within a wider distance of a class that holds a seed
   (hysteresis, as Canny's), labelled skin as a whole. A face or hand 20-40 pixels across
   fills few whole cells, and a cell on a hand's border mixes skin with background: the
   pixels find 5 of the 6 small faces of ``vtest`` (cells: 1) and 91 % of HGR's skin pixels
   (cells: 79 %), but they also take in skin-coloured wood and clothes that phase 2 sets
   aside, so the tracker keeps the paper's cells (on ``hand2`` the pixels' labels cost
   0.40 -> 0.13).
2. **Local clustering.** In each region, grown by one cell so that its border pixels are
   looked at too, the principal peaks of the I1, I2 and I3 histograms and the valleys that
   bound them define modes; a pixel's cluster is its region and the modes its I1, I2, I3
   fall in. A cluster is labelled skin when the mean and the variance of its (I2, I3) match
   a learnt skin class. A departure (``split_mixed``): a cluster refused is split in two
   by 2-means in (I2, I3) and each part judged alone, so that skin beside clothes of a
   near colour, which the histograms do not separate, is labelled too
   (:data:`MIXED_SKIN`, apart from the paper's :data:`SKIN`).

The skin classes are Gaussian clusters in the (I2, I3) plane learnt from labelled samples
(:func:`train_skin_model`, the ``human_tracker train-skin`` command) and shipped with the
package (:func:`default_skin_model`). :class:`SkinSegmenter` can adapt them online from
the tracked region, within a bounded distance of what was learnt. A person's own classes come
from their face (:mod:`~human_tracker.vision.cues.skin.face_skin`): the same segmentation with
the face's class in place of the general ones.
"""

from __future__ import annotations

from human_tracker.vision.cues.skin.clusters import histogram_modes
from human_tracker.vision.cues.skin.face_skin import FaceSkin, face_skin_class, face_skin_mask, frame_skin_model
from human_tracker.vision.cues.skin.model import (
    MIXED_SKIN,
    SKIN,
    SkinClass,
    SkinModel,
    default_skin_model,
    has_colour,
    ohta,
    train_skin_model,
)
from human_tracker.vision.cues.skin.parameters import REGION_METHODS, SkinParameters
from human_tracker.vision.cues.skin.regions import candidate_cells, cell_chroma, hysteresis_regions, merge_cells
from human_tracker.vision.cues.skin.segmenter import SkinSegmenter, segment_frame, segment_skin

__all__ = [
    'FaceSkin',
    'MIXED_SKIN',
    'REGION_METHODS',
    'SKIN',
    'SkinClass',
    'SkinModel',
    'SkinParameters',
    'SkinSegmenter',
    'candidate_cells',
    'cell_chroma',
    'hysteresis_regions',
    'default_skin_model',
    'face_skin_class',
    'face_skin_mask',
    'frame_skin_model',
    'has_colour',
    'histogram_modes',
    'merge_cells',
    'ohta',
    'segment_frame',
    'segment_skin',
    'train_skin_model',
]
