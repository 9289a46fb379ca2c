"""Texture swaps: replace named textures of the live model with images, once per episode (RL-ViGen's floor, table and wall textures)."""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Sequence

import mujoco
import numpy as np
import torch
import torch.nn.functional as F

from vigen.assets.image_bank import ImageBank
from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation
from vigen.transforms.scene.mujoco import named_id, texture_pixels


DEFAULT_TEXTURES = functools.partial(ImageBank.stand_in, 100, 256)
"""The texture bank of :class:`RandomTextures` without ``images``: 100 generated test-side stand-ins of side 256, seed 0."""


class RandomTextures(ScenePerturbation):
    """Draw named textures of the scene with different images, per episode or per fixed scene.

    RL-ViGen swaps the ground texture of its DMC tasks for one of 10 images per level, and the
    floor, wall, table and object textures of its robosuite scenes for images chosen per scene id
    (SECANT's presets). vigen draws one image per named texture from an
    :class:`~vigen.transforms.ImageBank`, writes it into the live model's texture pixels, resized to the
    texture's size (repeated on every face of a cube texture), and re-uploads it to the render
    context. With ``scene_id`` set, every episode gets the same draw, from that scene id.

    Without ``images`` it draws from test-side stand-ins, :data:`DEFAULT_TEXTURES`
    (:meth:`ImageBank.stand_in`: generated wood, marble, warped checkers and mosaics), not from the
    overlay augmentations' :meth:`ImageBank.builtin` (labmaze's textures and the training-side
    generated images): a texture level is a test level, and an agent trained with the default
    overlays must not be tested on its own training images.

    Paper: RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        textures: name or names of the textures to replace (dm_control's floor: ``"grid"``).
        images: an :class:`ImageBank`, a folder of images (which must exist; its images are read
            at the first reset), a function that returns a bank (called at the first reset), or
            ``None`` for the stand-in textures (:data:`DEFAULT_TEXTURES`).
        scene_id: a scene id that fixes the draw for every episode, or ``None`` to draw per episode.
        blend: weight of the new image, in [0, 1]: each texel is ``(1 - blend)·original + blend·image``
            (1: replaced, vigen's levels; lower values are the ``*_texture`` factors' intensities).
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", generalization="floor_texture", seed=0)
        >>> env.reset()["pixels"].shape
        torch.Size([9, 84, 84])
    """

    def __init__(
        self,
        textures: str | Sequence[str] = "grid",
        images: ImageBank | str | os.PathLike | Callable[[], ImageBank] | None = None,
        scene_id: int | None = None,
        blend: float = 1.0,
        seed: int | None = None,
    ) -> None:
        if isinstance(blend, bool) or not isinstance(blend, (int, float)) or not 0.0 <= blend <= 1.0:
            raise ValueError(f"RandomTextures: blend is the weight of the new image, a number in [0, 1]; got {blend!r}.")
        super().__init__(seed=seed)
        self.blend = float(blend)
        if isinstance(images, (str, os.PathLike)) and not os.path.isdir(os.path.expanduser(images)):
            # checked here, not at the first reset: inside a ParallelEnv worker that error would only kill the worker
            raise FileNotFoundError(
                f"RandomTextures: images={os.fspath(images)!r} is not a folder. Pass a folder of .jpg/.png images, an "
                "ImageBank, or None for the built-in bank."
            )
        self._images = images
        self.textures = (textures,) if isinstance(textures, str) else tuple(textures)
        self.scene_id = scene_id
        self._pixels: dict[tuple[int, int], np.ndarray] = {}

    @property
    def uses_stand_in(self) -> bool:
        """True for generated stand-in textures (the default, ``ImageBank.stand_in``), where the level's source shows image files."""
        images = self._images
        if images is None:
            return True
        if isinstance(images, ImageBank):
            return images.name.startswith("stand-in")
        if isinstance(images, (str, os.PathLike)):
            return False
        return "stand-in" in repr(images) or "stand_in" in getattr(getattr(images, "func", None), "__name__", "")

    @property
    def data_source(self) -> str:
        """What the textures are drawn from, e.g. ``"generated stand-in textures"`` or a user's folder (never its path).

        Examples:
            >>> RandomTextures().data_source, RandomTextures().uses_stand_in
            ('generated stand-in textures: stand-in', True)
        """
        kind = "generated stand-in textures" if self.uses_stand_in else "textures"
        return f"{kind}: {self._images_label()}"

    def _images_label(self) -> str:
        images = self._images
        if isinstance(images, functools.partial):
            return f"{images.func.__name__}({', '.join(map(repr, images.args))})"
        if isinstance(images, (str, os.PathLike)):
            return "a user folder of images"  # named, not its path: evaluation rows carry this label
        return str(images if isinstance(images, ImageBank) else (images or "stand-in"))

    @property
    def bank(self) -> ImageBank:
        self._images = ImageBank.load(DEFAULT_TEXTURES if self._images is None else self._images)
        return self._images

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        ids = np.array([named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, name) for name in self.textures])
        for name, texture in zip(self.textures, ids):
            if model.tex_nchannel[texture] not in (3, 4):
                raise ValueError(f"RandomTextures writes RGB(A) textures; {name!r} has {model.tex_nchannel[texture]} channels.")
        self._pixels = {}
        return {"textures": ids, **{f"original_{i}": texture_pixels(model, t).copy() for i, t in enumerate(ids)}}

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        if self.scene_id is not None:
            rng = np.random.default_rng(self.scene_id)
        return {"images": rng.integers(len(self.bank), size=len(self.textures))}

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {"images": np.full(len(self.textures), -1)}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        for index, (texture, image) in enumerate(zip(defaults["textures"], params["images"])):
            texture, image = int(texture), int(image)
            original = defaults[f"original_{index}"]
            pixels = original if image < 0 else self._texture_pixels(scene.model, texture, image)
            if image >= 0 and self.blend < 1.0:
                mixed = (1.0 - self.blend) * torch.from_numpy(original).float() + self.blend * torch.from_numpy(pixels).float()
                pixels = mixed.round_().clamp_(0, 255).to(torch.uint8).numpy()
            texture_pixels(scene.model, texture)[:] = pixels
            scene.upload_texture(texture)

    def _texture_pixels(self, model: object, texture: int, image: int) -> np.ndarray:
        """The image resized to the texture (each cube face gets the whole image), flat uint8 as MuJoCo stores it."""
        if (texture, image) not in self._pixels:
            width, height, channels = (int(x) for x in (model.tex_width[texture], model.tex_height[texture], model.tex_nchannel[texture]))
            faces = height // width if model.tex_type[texture] != mujoco.mjtTexture.mjTEXTURE_2D and height % width == 0 else 1
            resized = F.interpolate(self.bank.images[image][None].float(), size=(height // faces, width), mode="bilinear",
                                    antialias=True, align_corners=False)
            pixels = resized[0].round().clamp(0, 255).to(torch.uint8).permute(1, 2, 0).repeat(faces, 1, 1)
            if channels == 4:
                pixels = torch.cat([pixels, torch.full_like(pixels[..., :1], 255)], dim=-1)
            self._pixels[texture, image] = pixels.reshape(-1).numpy()
        return self._pixels[texture, image]

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        state["_pixels"] = {}
        return state

    def extra_repr(self) -> str:
        scene = "" if self.scene_id is None else f", scene_id={self.scene_id}"
        blend = "" if self.blend == 1.0 else f", blend={self.blend:g}"
        return f"textures={self.textures}, images={self._images_label()}{scene}{blend}"
