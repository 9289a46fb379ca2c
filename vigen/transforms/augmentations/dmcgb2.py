"""DMC-GB2's strong augmentations by name, as vigen augmentations."""

from __future__ import annotations

from vigen.transforms.augmentations.base import ImageAugmentation
from vigen.transforms.augmentations.compose import AugmentationChain, RandomChoice
from vigen.transforms.augmentations.conv import RandomConv
from vigen.transforms.augmentations.overlay import RandomOverlay
from vigen.transforms.augmentations.rotate import RandomRotate
from vigen.transforms.augmentations.shift import RandomShift

DMCGB2_AUGMENTATIONS = ("conv", "overlay", "conv_overlay", "rotate", "shift", "rotate_shift")
"""DMC-GB2's six strong augmentations; ``all`` is every one, ``photo`` the first three, ``geo`` the last three."""
_GROUPS = {"all": DMCGB2_AUGMENTATIONS, "photo": DMCGB2_AUGMENTATIONS[:3], "geo": DMCGB2_AUGMENTATIONS[3:]}


def _one(name: str) -> ImageAugmentation:
    if name == "conv":
        return RandomConv()
    if name == "overlay":
        return RandomOverlay(alpha=0.5)
    if name == "conv_overlay":
        return AugmentationChain([RandomConv(), RandomOverlay(alpha=0.5)])
    if name == "rotate":
        return RandomRotate(180)
    if name == "shift":
        return RandomShift(pad=16)
    return AugmentationChain([RandomRotate(180), RandomShift(pad=16)])


def dmcgb2_strong_augmentation(*names: str, seed: int | None = None) -> ImageAugmentation:
    """DMC-GB2's strong augmentation for ``names`` (its ``strong_augs``): one per sample, drawn uniformly.

    Names: ``conv`` (:class:`RandomConv`), ``overlay`` (:class:`RandomOverlay`, α 0.5),
    ``conv_overlay`` (conv then overlay), ``rotate`` (:class:`RandomRotate`, ±180°), ``shift``
    (:class:`RandomShift` with pad 16: DMC-GB2's ``random_shift`` is DrQ-v2's shift with a wider
    pad) and ``rotate_shift`` (rotate then shift); the groups ``all`` (the six, DMC-GB2's default
    for SADA), ``photo`` and ``geo``. With several, each sample gets one of them
    (:class:`RandomChoice`), as DMC-GB2's ``compose_augs``; one name gives that augmentation.
    The overlay uses vigen's built-in image bank; pass a ``RandomChoice`` of your own with
    ``RandomOverlay(images=<Places365 folder>)`` for the paper's images.

    Paper: DMC-GB2 / SADA, https://arxiv.org/abs/2405.17416.

    Examples:
        >>> from vigen.transforms import dmcgb2_strong_augmentation
        >>> type(dmcgb2_strong_augmentation("all")).__name__, len(dmcgb2_strong_augmentation("all").members)
        ('RandomChoice', 6)
        >>> dmcgb2_strong_augmentation("shift")
        RandomShift(pad=16, in_keys=['pixels'])
    """
    if not names:
        raise ValueError("dmcgb2_strong_augmentation needs at least one name, e.g. 'all'.")
    chosen: list[str] = []
    for name in names:
        if name in _GROUPS:
            chosen.extend(_GROUPS[name])
        elif name in DMCGB2_AUGMENTATIONS:
            chosen.append(name)
        else:
            raise ValueError(f"Unknown DMC-GB2 augmentation {name!r}; choose among {', '.join((*DMCGB2_AUGMENTATIONS, *_GROUPS))}.")
    if len(chosen) == 1:
        augmentation = _one(chosen[0])
        augmentation.set_seed(seed)
        return augmentation
    return RandomChoice([_one(name) for name in chosen], seed=seed)
