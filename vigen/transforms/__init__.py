"""Image augmentations (training time) and visual perturbations (evaluation time) as TorchRL Transforms.

Scene perturbations (``RandomSceneColors``, ``RandomMaterialColors``, ``RandomTextures``,
``RandomLighting``, ``RandomCamera``, ``VideoBackground``) edit the live MuJoCo model of the env
they sit in, once per episode (see :mod:`vigen.transforms.scene`); ``PixelCorruption`` corrupts
the pixels of any env.

Augmentations sample per-sample parameters (``make_params``) apart from applying them
(``apply``, backed by the pure kernels of :mod:`vigen.transforms.functional`):

========================  ==========================================================  ==========
transform                 what it does                                                paper
========================  ==========================================================  ==========
``RandomShift``           replicate-pad 4, random integer translation                 DrQ(-v2)
``RandomOverlay``         ``(1-α)·x + α·I`` with a natural image per sample            SVEA
``RandomConv``            random 3×3 RGB filter per sample, sigmoid                   DMC-GB
``RandomFrequencyMask``   remove a random square ring of spatial frequencies         SRM
``RandomCrop``            random window (render larger, crop to 84)                  CURL
``CenterCrop``            central window (evaluation counterpart of RandomCrop)      CURL
``RandomColorJitter``     brightness, contrast, saturation, hue per sample            —
========================  ==========================================================  ==========

This room may import torch, torchrl, tensordict, numpy, OpenCV (image decoding) and mujoco
(scene edits only), never ``vigen.envs`` or ``vigen.losses``.
"""

from vigen.transforms.augmentation import ImageAugmentation
from vigen.transforms.camera import RandomCamera
from vigen.transforms.color_jitter import RandomColorJitter
from vigen.transforms.conv import RandomConv
from vigen.transforms.corruptions import PixelCorruption
from vigen.transforms.crop import CenterCrop, RandomCrop
from vigen.transforms.frequency import RandomFrequencyMask
from vigen.transforms.image_bank import ImageBank
from vigen.transforms.lighting import RandomLighting
from vigen.transforms.material_colors import RandomMaterialColors
from vigen.transforms.overlay import RandomOverlay
from vigen.transforms.scene import ScenePerturbation, SceneHandle
from vigen.transforms.scene_colors import RandomSceneColors, load_dmcgb_palette
from vigen.transforms.shift import RandomShift
from vigen.transforms.textures import RandomTextures
from vigen.transforms.video import VideoBackground
from vigen.transforms.video_source import VideoSource

__all__ = [
    "CenterCrop",
    "ImageAugmentation",
    "ImageBank",
    "RandomColorJitter",
    "RandomConv",
    "RandomCrop",
    "RandomFrequencyMask",
    "RandomOverlay",
    "RandomShift",
    "RandomCamera",
    "RandomLighting",
    "RandomMaterialColors",
    "RandomSceneColors",
    "SceneHandle",
    "ScenePerturbation",
    "load_dmcgb_palette",
    "PixelCorruption",
    "RandomTextures",
    "VideoBackground",
    "VideoSource",
]
