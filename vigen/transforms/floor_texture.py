"""Floor textures: replace the floor grid's texture with an image, once per episode (RL-ViGen's table/ground textures)."""

from __future__ import annotations

import os

import mujoco
import numpy as np
import torch
import torch.nn.functional as F

from vigen.transforms.image_bank import ImageBank
from vigen.transforms.scene import Defaults, SceneHandle, SceneParams, ScenePerturbation
from vigen.transforms.scene_colors import _named_id, _texture


class RandomFloorTexture(ScenePerturbation):
    """Draw the floor with a different texture image every episode.

    RL-ViGen swaps the ground (or table) texture for one of 10 images per level; vigen draws from
    an :class:`~vigen.transforms.ImageBank` (by default the built-in one, whose labmaze floor and
    wall textures are made for this) and writes it into the live model's ``grid`` texture,
    resized to the texture's size, then re-uploads it to the render context.

    Paper: RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        images: an :class:`ImageBank`, a folder of images, or ``None`` for the built-in bank.
        texture: name of the floor texture in the model (dm_control's suite: ``"grid"``).
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", generalization="floor_texture", seed=0)
        >>> env.reset()["pixels"].shape
        torch.Size([9, 84, 84])
    """

    def __init__(self, images: ImageBank | str | os.PathLike | None = None, texture: str = "grid", seed: int | None = None) -> None:
        super().__init__(seed=seed)
        self._images = images
        self.texture = texture

    @property
    def bank(self) -> ImageBank:
        self._images = ImageBank.load(self._images)
        return self._images

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        texture = _named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, self.texture)
        if model.tex_nchannel[texture] != 3:
            raise ValueError(f"RandomFloorTexture writes RGB textures; {self.texture!r} has {model.tex_nchannel[texture]} channels.")
        return {"texture": np.array(texture), "original": _texture(model, texture).copy()}

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        return {"image": int(rng.integers(len(self.bank)))}

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {"image": -1}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        model, texture = scene.model, int(defaults["texture"])
        if params["image"] < 0:
            pixels = defaults["original"]
        else:
            size = (int(model.tex_height[texture]), int(model.tex_width[texture]))
            image = self.bank.images[params["image"]][None].float()
            image = F.interpolate(image, size=size, mode="bilinear", antialias=True, align_corners=False)
            pixels = image[0].round().clamp(0, 255).to(torch.uint8).permute(1, 2, 0).reshape(-1).numpy()
        _texture(model, texture)[:] = pixels
        scene.upload_texture(texture)

    def extra_repr(self) -> str:
        source = self._images if isinstance(self._images, ImageBank) else (self._images or "builtin")
        return f"images={source!s}"
