"""Datasets of observed SPL images: synthetic generators, external loaders, the
container and its on-disk format, and pictures.

Public API:

- ``Dataset``: N observed images with targets, split, condition, level, clean depth,
  reflectivity and SIV variants; ``save`` / ``load`` / ``subset`` / ``groups``.
- ``make_classification_dataset``: the 11 procedural object categories, observed.
- ``make_segmentation_dataset``: procedural street scenes with per-pixel labels, observed.
- ``load_folder``: the authors' released layout or a generic ``root/{class}/`` folder.
- ``load_unlabeled_folder``: depth files without labels, the pool of a human oracle.
- ``spl_al.data.sources`` (imported on its own): one module per config ``source``
  behind a registry; ``build_dataset(entry)`` makes a config entry's dataset.
- ``observe``: observed images of clean depth at per-sample conditions.
- ``contact_sheet``, ``variants_sheet``: PNG pictures of a dataset.
- ``validation_split``: a seeded, class-stratified cut of the training pool for tuning.
"""

from spl_al.data.dataset import LEVELS, SCENE_FIELDS, Dataset
from spl_al.data.external import load_folder
from spl_al.data.observe import DEFAULT_LEVELS, DEFAULT_SBR, condition_set, observe
from spl_al.data.pictures import contact_sheet, variants_sheet
from spl_al.data.procedural import make_classification_dataset, make_segmentation_dataset
from spl_al.data.unlabeled_folder import load_unlabeled_folder
from spl_al.data.validation import validation_split

__all__ = [
    "DEFAULT_LEVELS",
    "DEFAULT_SBR",
    "LEVELS",
    "SCENE_FIELDS",
    "Dataset",
    "condition_set",
    "contact_sheet",
    "load_folder",
    "load_unlabeled_folder",
    "make_classification_dataset",
    "make_segmentation_dataset",
    "observe",
    "validation_split",
    "variants_sheet",
]
