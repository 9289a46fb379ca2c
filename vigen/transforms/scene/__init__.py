"""Evaluation-time scene perturbations: Transforms that act on the live MuJoCo scene of the env they sit in.

``RandomSceneColors``, ``RandomMaterialColors``, ``PresetMaterialColors``, ``RandomTextures``, ``RandomLighting`` and
``RandomCamera`` edit the model once per episode (and may move things every step);
``VideoBackground`` composites video frames into the rendered frames where the scene's
segmentation shows background. This room may import torch, torchrl, numpy and mujoco, never
``vigen.envs`` or ``vigen.losses``.
"""

from vigen.transforms.scene.base import SceneHandle, ScenePerturbation, SceneTransform
from vigen.transforms.scene.camera import RandomCamera
from vigen.transforms.scene.colors import RandomSceneColors
from vigen.transforms.scene.distracting import DistractingCamera, DistractingColors
from vigen.transforms.scene.dmcgb2_camera import DMCGB2Camera
from vigen.transforms.scene.dmcgb2_video import DMCGB2VideoBackground
from vigen.transforms.scene.lighting import RandomLighting
from vigen.transforms.scene.material_colors import PresetMaterialColors, RandomMaterialColors
from vigen.transforms.scene.rlvigen_draws import RLViGenDraws
from vigen.transforms.scene.textures import RandomTextures
from vigen.transforms.scene.video import VideoBackground

__all__ = [
    "DMCGB2Camera", "DistractingCamera", "DistractingColors",
    "DMCGB2VideoBackground",
    "PresetMaterialColors",
    "RLViGenDraws",
    "RandomCamera",
    "RandomLighting",
    "RandomMaterialColors",
    "RandomSceneColors",
    "RandomTextures",
    "SceneHandle",
    "ScenePerturbation",
    "SceneTransform",
    "VideoBackground",
]
