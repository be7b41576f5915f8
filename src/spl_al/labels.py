"""Label conventions shared by every part of spl-al."""

IGNORE_INDEX = 255
