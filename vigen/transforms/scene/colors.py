"""DMC-GB's colour shifts: floor grid, skybox and the agent's body, recoloured in the live model."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
import torch

from vigen.assets.palettes import PALETTE_KEYS, check_palette, load_dmcgb_palette
from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation
from vigen.transforms.scene.mujoco import named_id, texture_pixels

PARTS = ("grid", "skybox", "self")


class RandomSceneColors(ScenePerturbation):
    """Recolour the floor grid, the skybox and the agent's ``self`` material once per episode (DMC-GB).

    DMC-GB draws one of 100 presets per episode and reloads the physics from rewritten XML;
    vigen edits the live model instead (material colour, and the texture pixels of the grid and
    the skybox, re-uploaded to the render context), which gives the same colours without a
    recompile. Without a palette file, colours are drawn the way the presets were made (measured
    from DMC-GB's files): each channel of ``grid_rgb1``, ``skybox_rgb`` and ``self_rgb`` is its
    default plus N(0, ``scale``²), clipped to [0, 1], and ``grid_rgb2 = grid_rgb1 + 0.1`` (the
    default offset). ``scale`` is 0.1 for DMC-GB's ``color_easy`` and 0.2 for ``color_hard``. With
    ``palette`` (a DMC-GB ``color_*.pt`` file or a list of its entries) one entry is drawn per
    episode, uniformly.

    Texture edits keep each texture's structure: the checker's two tones and the sky gradient's
    two ends are mapped to the new colours, and the sky's white stars stay white.

    Paper: DMC-GB / SODA, https://arxiv.org/abs/2011.13389.

    Args:
        scale: standard deviation of the colour noise (ignored with ``palette``).
        palette: DMC-GB preset file or entries.
        parts: which of ``"grid"``, ``"skybox"``, ``"self"`` to recolour (RL-ViGen's
            ``objects_color`` is ``("self",)``).
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import RandomSceneColors
        >>> env = make_env("dmc/walker-walk").append_transform(RandomSceneColors(scale=0.2, seed=0))
        >>> env.reset()["pixels"].shape
        torch.Size([9, 84, 84])
    """

    def __init__(
        self,
        scale: float = 0.1,
        palette: str | os.PathLike | Sequence[dict[str, Any]] | None = None,
        parts: Sequence[str] = PARTS,
        seed: int | None = None,
    ) -> None:
        unknown = set(parts) - set(PARTS)
        if unknown:
            raise ValueError(f"Unknown parts {sorted(unknown)}; choose from {PARTS}.")
        super().__init__(seed=seed)
        self.scale = scale
        self.palette_source = palette if palette is None or isinstance(palette, (str, os.PathLike)) else "entries"
        if palette is None or isinstance(palette, (str, os.PathLike)):
            self.palette = None if palette is None else load_dmcgb_palette(palette)
        else:  # entries given in code: checked now, not at the first reset
            self.palette = check_palette(list(palette) if isinstance(palette, Sequence) else palette, "RandomSceneColors(palette=...)")
        self.parts = tuple(parts)

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        defaults: Defaults = {}
        if "self" in self.parts:
            material = named_id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "self")
            defaults["self_material"] = np.array(material)
            defaults["self_rgb"] = model.mat_rgba[material, :3].copy()
        if "grid" in self.parts:
            texture = named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, "grid")
            raw = texture_pixels(model, texture).reshape(-1, 3)
            packed = (raw[:, 0].astype(np.int32) << 16) | (raw[:, 1].astype(np.int32) << 8) | raw[:, 2]
            values, counts = np.unique(packed, return_counts=True)
            tones = [np.array([(v >> 16) & 255, (v >> 8) & 255, v & 255]) / 255 for v in values[np.argsort(counts)[-2:]]]
            dark, light = sorted(tones, key=np.sum)
            defaults.update(_two_tone(raw, dark, light, "grid"), grid_texture=np.array(texture))
            defaults["grid_rgb1"], defaults["grid_rgb2"] = dark, light
        if "skybox" in self.parts:
            texture = named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, "skybox")
            raw = texture_pixels(model, texture).reshape(-1, 3)
            sky = torch.from_numpy(raw)[torch.from_numpy(raw != 255).any(dim=1)]  # without the white stars
            top, bottom = sky.amax(dim=0).double().numpy() / 255, sky.amin(dim=0).double().numpy() / 255
            defaults.update(_two_tone(raw, bottom, top, "skybox"), skybox_texture=np.array(texture))
            defaults["skybox_rgb"], defaults["skybox_bottom"] = top, bottom
        return defaults

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        if self.palette is not None:
            entry = self.palette[rng.integers(len(self.palette))]
            return {key: np.asarray(entry[key], dtype=np.float64) for key in PALETTE_KEYS}
        params = {key: np.clip(defaults[key] + rng.normal(0, self.scale, 3), 0, 1) for key in PALETTE_KEYS
                  if key in defaults and key != "grid_rgb2"}
        if "grid_rgb1" in params:
            params["grid_rgb2"] = np.clip(params["grid_rgb1"] + defaults["grid_rgb2"] - defaults["grid_rgb1"], 0, 1)
        return params

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {key: defaults[key] for key in PALETTE_KEYS if key in defaults}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        model = scene.model
        if "self" in self.parts:
            model.mat_rgba[int(defaults["self_material"]), :3] = params["self_rgb"]
        if "grid" in self.parts:
            _write_two_tone(scene, defaults, "grid", params["grid_rgb1"], params["grid_rgb2"])
        if "skybox" in self.parts:
            _write_two_tone(scene, defaults, "skybox", defaults["skybox_bottom"], params["skybox_rgb"])

    def extra_repr(self) -> str:
        source = f"palette={self.palette_source!s}" if self.palette is not None else f"scale={self.scale}"
        return f"{source}, parts={self.parts}"


def _two_tone(raw: np.ndarray, low: np.ndarray, high: np.ndarray, name: str) -> Defaults:
    """Where each uint8 pixel lies between two colours (``t``), and which lie off that segment (kept as they are)."""
    pixels_t = torch.from_numpy(raw).float().div_(255)
    low_t, direction = torch.from_numpy(low).float(), torch.from_numpy(high - low).float()
    t = ((pixels_t - low_t) @ direction / (direction @ direction)).clamp_(0, 1).mul_(1e5).round_().div_(1e5)
    residual = (pixels_t - low_t - t[:, None] * direction).abs_().amax(dim=1)
    keep = (residual > 2 / 255).numpy()
    return {
        f"{name}_t": t.unsqueeze(-1),
        f"{name}_keep": np.flatnonzero(keep),
        f"{name}_kept": raw[keep].copy(),
    }


def _write_two_tone(scene: SceneHandle, defaults: Defaults, name: str, low: np.ndarray, high: np.ndarray) -> None:
    texture = int(defaults[f"{name}_texture"])
    t, keep = defaults[f"{name}_t"], defaults[f"{name}_keep"]
    low, high = (torch.from_numpy(255 * c).float() for c in (low, high))
    colors = torch.lerp(low, high, t).round_().to(torch.uint8).numpy()  # lerp is exact at t = 0 and 1
    colors[keep] = defaults[f"{name}_kept"]
    texture_pixels(scene.model, texture)[:] = colors.reshape(-1)
    scene.upload_texture(texture)
