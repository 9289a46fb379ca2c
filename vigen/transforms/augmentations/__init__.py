"""Training-time image augmentations as TorchRL Transforms, with the pure kernels that apply sampled parameters.

Each augmentation samples per-sample parameters (``make_params``) apart from applying them
(``apply``, backed by :mod:`vigen.transforms.augmentations.functional`), so one draw can be
replayed and tested.
"""

from vigen.transforms.augmentations.base import ImageAugmentation
from vigen.transforms.augmentations.color_jitter import RandomColorJitter
from vigen.transforms.augmentations.compose import AugmentationChain, RandomChoice
from vigen.transforms.augmentations.conv import RandomConv
from vigen.transforms.augmentations.crop import CenterCrop, RandomCrop
from vigen.transforms.augmentations.dmcgb2 import DMCGB2_AUGMENTATIONS, dmcgb2_strong_augmentation
from vigen.transforms.augmentations.frequency import RandomFrequencyMask
from vigen.transforms.augmentations.overlay import RandomOverlay
from vigen.transforms.augmentations.rotate import RandomRotate
from vigen.transforms.augmentations.shifted_overlay import RandomShiftedOverlay
from vigen.transforms.augmentations.shift import RandomShift

__all__ = [
    "AugmentationChain",
    "CenterCrop",
    "DMCGB2_AUGMENTATIONS",
    "ImageAugmentation",
    "RandomChoice",
    "RandomColorJitter",
    "RandomConv",
    "RandomCrop",
    "RandomFrequencyMask",
    "RandomOverlay",
    "RandomRotate",
    "RandomShiftedOverlay",
    "RandomShift",
    "dmcgb2_strong_augmentation",
]
