"""Image augmentations (training time) and visual perturbations (evaluation time) as TorchRL Transforms.

Scene perturbations (``RandomSceneColors``, ``RandomMaterialColors``, ``RandomTextures``,
``RandomLighting``, ``RandomCamera``, ``VideoBackground``) edit the live MuJoCo model of the env
they sit in, once per episode (see :mod:`vigen.transforms.scene`; ``VideoBackground`` composites frames by segmentation); ``PixelCorruption`` corrupts
the pixels of any env. The sub-packages: :mod:`vigen.transforms.augmentations` (training time),
:mod:`vigen.transforms.scene` (evaluation time, MuJoCo scenes); images and videos come from
:mod:`vigen.assets`.

Augmentations sample per-sample parameters (``make_params``) apart from applying them
(``apply``, backed by the pure kernels of :mod:`vigen.transforms.augmentations.functional`):

========================  ==========================================================  ==========
transform                 what it does                                                paper
========================  ==========================================================  ==========
``RandomShift``           replicate-pad 4, random integer translation (pad 16: DMC-GB2)  DrQ(-v2)
``RandomOverlay``         ``(1-α)·x + α·I`` with a natural image per sample            SVEA
``RandomShiftedOverlay``  overlay whose image crop drifts by (dy, dx) per frame       SimGRL
``RandomConv``            random 3×3 RGB filter per sample, sigmoid                   DMC-GB
``RandomFrequencyMask``   remove a random square ring of spatial frequencies         SRM
``RandomCrop``            random window (render larger, crop to 84)                  CURL
``CenterCrop``            central window (evaluation counterpart of RandomCrop)      CURL
``RandomColorJitter``     brightness, contrast, saturation, hue per sample            —
``RandomRotate``          turn by an angle in [-180°, 180°] per sample, edge fill     DMC-GB2
``AugmentationChain``     members one after another (rotate+shift, conv+overlay)      DMC-GB2
``RandomChoice``          one member per sample, uniformly                            DMC-GB2
========================  ==========================================================  ==========

This room may import torch, torchrl, tensordict, numpy, OpenCV (image decoding) and mujoco
(scene edits only), never ``vigen.envs`` or ``vigen.losses``.
"""

from vigen.assets import ImageBank, VideoSource, load_dmcgb_palette
from vigen.transforms.augmentations import (
    DMCGB2_AUGMENTATIONS,
    AugmentationChain,
    CenterCrop,
    ImageAugmentation,
    RandomChoice,
    RandomColorJitter,
    RandomConv,
    RandomCrop,
    RandomFrequencyMask,
    RandomOverlay,
    RandomRotate,
    RandomShiftedOverlay,
    RandomShift,
    dmcgb2_strong_augmentation,
)
from vigen.transforms.corruptions import PixelCorruption
from vigen.transforms.scene import DistractingCamera, DistractingColors, DMCGB2Camera
from vigen.transforms.scene import DMCGB2VideoBackground
from vigen.transforms.scene import (
    PresetMaterialColors,
    RLViGenDraws,
    RandomCamera,
    RandomLighting,
    RandomMaterialColors,
    RandomSceneColors,
    RandomTextures,
    SceneHandle,
    ScenePerturbation,
    SceneTransform,
    VideoBackground,
)

__all__ = [
    "DMCGB2Camera", "DistractingCamera", "DistractingColors",
    "DMCGB2VideoBackground",
    "PresetMaterialColors",
    "RLViGenDraws",
    "AugmentationChain",
    "CenterCrop",
    "DMCGB2_AUGMENTATIONS",
    "ImageAugmentation",
    "RandomChoice",
    "RandomRotate",
    "dmcgb2_strong_augmentation",
    "ImageBank",
    "RandomColorJitter",
    "RandomConv",
    "RandomCrop",
    "RandomFrequencyMask",
    "RandomOverlay",
    "RandomShiftedOverlay",
    "RandomShift",
    "RandomCamera",
    "RandomLighting",
    "RandomMaterialColors",
    "RandomSceneColors",
    "SceneHandle",
    "SceneTransform",
    "ScenePerturbation",
    "load_dmcgb_palette",
    "PixelCorruption",
    "RandomTextures",
    "VideoBackground",
    "VideoSource",
]
