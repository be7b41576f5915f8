"""Label conventions shared by every part of spl_al."""

IGNORE_INDEX = 255
