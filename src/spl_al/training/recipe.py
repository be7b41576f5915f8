"""The training recipe: ``TrainConfig``."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields

STEPS_BY = ("groups", "images")
"""What ``TrainConfig.epochs`` counts passes over: the labeled groups, or every image."""


@dataclass(frozen=True)
class TrainConfig:
    """How to train one model; independent of the seed and of where it runs (both
    passed to ``train``: the seed, and a ``Compute`` with the device, threads and
    precision).

    Attributes:
        epochs: passes over the training set (used when ``steps`` is None): over the
            labeled groups or over every image, as ``steps_by`` says.
        steps: total optimiser steps; when set it overrides ``epochs``.
        steps_by: what an epoch's steps count: "groups" (the default) gives an epoch
            n_groups // batch_size steps, so a method that trains on each labeled
            group's variants takes the steps of one that trains on the observed
            images alone (it sees each image less often): methods compared at a
            budget differ in what they acquire, not in how long they train. "images"
            gives an epoch n_images // batch_size steps: variants add steps. Both are
            the same when each image is its own group.
        min_steps: at least this many steps (more epochs when the labeled set is
            small, so early rounds are not under-trained); 0 disables.
        steps_per_group: at least this many steps per labeled group (``train``'s
            ``groups``; each image is its own group when it is not given); 0
            disables. The labels, not the images, then set how long a round trains:
            a method that trains on a group's variants gets the steps of one that
            does not at the same budget, and a larger budget trains longer.
        batch_size: images per step (the whole set when it is smaller).
        lr: peak learning rate of SGD.
        momentum, nesterov, weight_decay: SGD settings (decay on every parameter).
        cosine: cosine annealing from ``lr`` to 0 over all steps (else constant).
        hflip: random horizontal flips (image and mask) as augmentation.
        shift: random translations of up to this fraction of the image height and
            width (each image its own integer shift; pixels shifted in are voids,
            masks shift alike); 0 disables. The cheapest strong prior for few labels:
            a class does not change when the object moves in the frame.
        rotate_deg: random rotations of each image by up to this many degrees (nearest
            sampling: depths are moved, never blended; what rotates in is void,
            masks rotate alike); 0 disables.
        scale: random zoom of each image by a factor in [1 - scale, 1 + scale]
            (nearest sampling, like ``rotate_deg``); 0 disables.
        crop_width: train on a random window of this fraction of the image width,
            each image its own (masks cropped alike); 1 disables. Prediction still
            sees whole images (a convolutional net takes any width). For range images,
            whose classes are local, a step of half-width windows costs half a step of
            whole ones, so the same time buys twice the steps.
        mixup: classification only: train on convex mixtures of two images of a batch
            and of their one-hot labels, the weight drawn per image from
            Beta(mixup, mixup) (Zhang et al. 2018); 0 disables.
        balance: weight each class's loss by n_c^-balance, n_c its units (pixels,
            points or images) in the training targets, so rare classes count more
            (0.5: inverse square root, 1: inverse frequency); 0 disables. Applies to
            the hard-label loss (not to mixup or label-smoothing targets).
        label_smoothing: classification only: the target puts this mass uniformly
            over the classes; 0 disables.
        from_scratch: re-initialise the weights from the seed before training.
        channels_last: NHWC memory layout (about 2x faster convolutions on CPU).
        log_every: write a progress line every this many epochs (0: none).
        eval_batch_size: images per forward pass in prediction and evaluation.
    """

    epochs: int | None = 30
    steps: int | None = None
    steps_by: str = "groups"
    min_steps: int = 0
    steps_per_group: int = 0
    batch_size: int = 128
    lr: float = 0.05
    momentum: float = 0.9
    nesterov: bool = False
    weight_decay: float = 5e-4
    cosine: bool = True
    hflip: bool = True
    shift: float = 0.0
    rotate_deg: float = 0.0
    scale: float = 0.0
    crop_width: float = 1.0
    balance: float = 0.0
    mixup: float = 0.0
    label_smoothing: float = 0.0
    from_scratch: bool = True
    channels_last: bool = True
    log_every: int = 1
    eval_batch_size: int = 256

    def __post_init__(self) -> None:
        def positive_int(name: str, value, allow_none: bool = False, minimum: int = 1) -> None:
            if value is None and allow_none:
                return
            if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
                raise ValueError(
                    f"TrainConfig.{name} must be an integer >= {minimum}, got {value!r}."
                )

        positive_int("epochs", self.epochs, allow_none=True)
        positive_int("steps", self.steps, allow_none=True)
        if self.epochs is None and self.steps is None:
            raise ValueError("TrainConfig needs epochs or steps; both are None.")
        positive_int("min_steps", self.min_steps, minimum=0)
        positive_int("steps_per_group", self.steps_per_group, minimum=0)
        positive_int("batch_size", self.batch_size)
        positive_int("log_every", self.log_every, minimum=0)
        positive_int("eval_batch_size", self.eval_batch_size)
        bounds = {
            "shift": (0, 0.5),
            "rotate_deg": (0, 180),
            "scale": (0, 1),
            "label_smoothing": (0, 1),
        }
        for name, (low, high) in bounds.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"TrainConfig.{name} must be a number, got {value!r}.")
            if not low <= value < high:
                raise ValueError(f"TrainConfig.{name} must lie in [{low}, {high}), got {value!r}.")
        if (
            isinstance(self.crop_width, bool)
            or not isinstance(self.crop_width, int | float)
            or not 0 < self.crop_width <= 1
        ):
            raise ValueError(
                f"TrainConfig.crop_width must be a number in (0, 1], got {self.crop_width!r}."
            )
        for name in ("lr", "momentum", "weight_decay", "mixup", "balance"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not value >= 0:
                raise ValueError(f"TrainConfig.{name} must be a number >= 0, got {value!r}.")
        if self.steps_by not in STEPS_BY:
            raise ValueError(
                f"TrainConfig.steps_by must be one of {list(STEPS_BY)}, got {self.steps_by!r}."
            )
        for name in ("nesterov", "cosine", "hflip", "from_scratch", "channels_last"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(
                    f"TrainConfig.{name} must be true or false, got {getattr(self, name)!r}."
                )

    @classmethod
    def from_dict(cls, params: Mapping | None) -> TrainConfig:
        """Config from a mapping (e.g. a YAML section); missing keys keep their defaults."""
        return cls(**known_fields(cls, params, "unknown TrainConfig keys"))

    @classmethod
    def paper(cls) -> TrainConfig:
        """The paper's protocol: 200 epochs, SGD momentum 0.9, lr 0.1, batch 512, cosine."""
        return cls(epochs=200, batch_size=512, lr=0.1, momentum=0.9, weight_decay=5e-4)

    def to_dict(self) -> dict:
        """The fields as a plain dict (``from_dict`` reads it back)."""
        return asdict(self)

    def total_steps(self, n_images: int, n_groups: int | None = None) -> int:
        """Optimiser steps for ``n_images`` training images from ``n_groups`` labeled
        groups (None: one group per image):
        max(steps or epochs * (n // batch_size), min_steps, steps_per_group * n_groups),
        n = n_groups with ``steps_by`` "groups", n_images with "images" (an epoch
        has at least one step)."""
        groups = n_images if n_groups is None else n_groups
        n = groups if self.steps_by == "groups" else n_images
        per_epoch = max(1, n // self.batch_size)
        steps = self.steps if self.steps is not None else self.epochs * per_epoch
        return max(steps, self.min_steps, self.steps_per_group * groups)

    def batch_images(self, n_images: int) -> int:
        """Images per step: ``batch_size``, or all ``n_images`` when there are fewer."""
        return min(self.batch_size, n_images)

    def images_seen(self, n_images: int, n_groups: int | None = None) -> int:
        """Images drawn over the whole training: ``total_steps`` x ``batch_images``
        (exact: every batch is full, an epoch drops its ragged last batch)."""
        return self.total_steps(n_images, n_groups) * self.batch_images(n_images)


def known_fields(cls, values: Mapping | None, unknown_words: str) -> dict:
    """``values`` as a dict when every key is a field of dataclass ``cls``; else a
    one-sentence ValueError, ``unknown_words`` followed by the keys and the fields."""
    values = dict(values or {})
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise ValueError(f"{unknown_words} {unknown}; expected some of {sorted(known)}.")
    return values
