"""Training-time image augmentations as TorchRL Transforms, with the pure kernels that apply sampled parameters.

Each augmentation samples per-sample parameters (``make_params``) apart from applying them
(``apply``, backed by :mod:`vigen.transforms.augmentations.functional`), so one draw can be
replayed and tested.
"""

from vigen.transforms.augmentations.base import ImageAugmentation
from vigen.transforms.augmentations.color_jitter import RandomColorJitter
from vigen.transforms.augmentations.conv import RandomConv
from vigen.transforms.augmentations.crop import CenterCrop, RandomCrop
from vigen.transforms.augmentations.frequency import RandomFrequencyMask
from vigen.transforms.augmentations.overlay import RandomOverlay
from vigen.transforms.augmentations.shifted_overlay import RandomShiftedOverlay
from vigen.transforms.augmentations.shift import RandomShift

__all__ = [
    "CenterCrop",
    "ImageAugmentation",
    "RandomColorJitter",
    "RandomConv",
    "RandomCrop",
    "RandomFrequencyMask",
    "RandomOverlay",
    "RandomShiftedOverlay",
    "RandomShift",
]
