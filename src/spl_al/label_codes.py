"""Label conventions shared by every part of spl_al."""

IGNORE_INDEX = 255  # segmentation: a pixel without a label (sky, no return, not given)
UNKNOWN_CLASS = -1  # classification: a sample whose class nobody has given yet
