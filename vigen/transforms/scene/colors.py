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
from vigen.transforms.scene.builtin_textures import (
    CUBE_FACES,
    cube_gradient,
    cube_gradient_alphas,
    edge_ring,
    fit_gradient_top,
    to_bytes,
)
from vigen.transforms.scene.dmcgb2_seed import check_source_seed, photometric_start, resolve_source_seed
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
    episode, uniformly. With ``dmcgb2_colors`` (DMC-GB2's ``envs/dmcgb/data/color_{easy,hard}.pt``,
    or its entries) the entries are cycled as DMC-GB2 does (``dmcgb_photometric.py:53, 58, 176-179``):
    episode ``k`` shows entry ``(start + k) % len(entries)`` with ``start =
    np.random.RandomState(s).randint(100)`` for the env seed ``s`` (the seed of the vigen env the
    transform sits in, or ``source_seed``; see :mod:`~vigen.transforms.scene.dmcgb2_seed`), so a
    vigen env and a DMC-GB2 env seeded alike show the same colours in the same episodes.

    Texture edits keep each texture's structure: the checker's two tones and the sky gradient's
    two ends are mapped to the new colours, and the sky's white stars stay white. With
    ``rebuild_textures`` (implied by ``dmcgb2_colors``) the pixels are those MuJoCo builds from the
    new colours when DMC-GB / DMC-GB2 recompile the XML (:mod:`~vigen.transforms.scene.builtin_textures`):
    colours become bytes by truncation, the grid's edge marks keep their ``markrgb`` (neither
    source edits it), and the sky is MuJoCo's gradient recomputed for the new top colour; a
    texture that is not MuJoCo's builtin checker / gradient keeps the tone mapping.

    Paper: DMC-GB / SODA, https://arxiv.org/abs/2011.13389.

    Args:
        scale: standard deviation of the colour noise (ignored with ``palette``).
        palette: DMC-GB preset file or entries.
        parts: which of ``"grid"``, ``"skybox"``, ``"self"`` to recolour (RL-ViGen's
            ``objects_color`` is ``("self",)``).
        rebuild_textures: write the textures MuJoCo builds for the new colours (see above).
        dmcgb2_colors: DMC-GB2 preset file or entries, cycled from a seeded start (exclusive with ``palette``);
            or DMC-GB2's data folder (``envs/dmcgb/data``), read at ``dmcgb2_file``.
        dmcgb2_file: the preset file to read in a ``dmcgb2_colors`` folder (the levels set ``color_easy.pt``
            or ``color_hard.pt``, so one folder serves every DMC-GB2 colour level).
        source_seed: DMC-GB2's env seed for ``dmcgb2_colors``' start; ``None``: the vigen env's seed.
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
        rebuild_textures: bool = False,
        dmcgb2_colors: str | os.PathLike | Sequence[dict[str, Any]] | None = None,
        dmcgb2_file: str | None = None,
        source_seed: int | None = None,
        seed: int | None = None,
    ) -> None:
        unknown = set(parts) - set(PARTS)
        if unknown:
            raise ValueError(f"Unknown parts {sorted(unknown)}; choose from {PARTS}.")
        if palette is not None and dmcgb2_colors is not None:
            raise ValueError("RandomSceneColors: palette (DMC-GB: one entry drawn per episode) and dmcgb2_colors (DMC-GB2: "
                             "entries cycled from a seeded start) choose the colours two ways; pass one of them.")
        if not isinstance(rebuild_textures, bool):
            raise TypeError(f"RandomSceneColors: rebuild_textures is True or False, got {rebuild_textures!r}.")
        source_seed = check_source_seed(source_seed, "RandomSceneColors")
        super().__init__(seed=seed)
        self.source_seed = source_seed
        self.scale = scale
        self.cycle = dmcgb2_colors is not None
        given = dmcgb2_colors if self.cycle else palette
        option = "dmcgb2_colors" if self.cycle else "palette"
        self.palette_source = given if given is None or isinstance(given, (str, os.PathLike)) else "entries"
        if given is None:
            self.palette = None
        elif isinstance(given, (str, os.PathLike)):
            self.palette = _load_dmcgb2_colors(given, dmcgb2_file) if self.cycle else load_dmcgb_palette(given)
        else:  # entries given in code: checked now, not at the first reset
            self.palette = check_palette(list(given) if isinstance(given, Sequence) else given, f"RandomSceneColors({option}=...)")
        self.rebuild_textures = rebuild_textures or self.cycle
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
            grid = _two_tone(raw, dark, light, "grid")
            if self.rebuild_textures:
                grid = _keep_edge_marks(grid, raw, model.tex_height[texture], model.tex_width[texture])
            defaults.update(grid, grid_texture=np.array(texture))
            defaults["grid_rgb1"], defaults["grid_rgb2"] = dark, light
        if "skybox" in self.parts:
            texture = named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, "skybox")
            raw = texture_pixels(model, texture).reshape(-1, 3)
            sky = torch.from_numpy(raw)[torch.from_numpy(raw != 255).any(dim=1)]  # without the white stars
            top, bottom = sky.amax(dim=0).double().numpy() / 255, sky.amin(dim=0).double().numpy() / 255
            defaults["skybox_rgb"], defaults["skybox_bottom"] = top, bottom
            gradient = _gradient_skybox(raw, model.tex_width[texture], model.tex_height[texture], top, bottom) \
                if self.rebuild_textures else None
            defaults.update(gradient or _two_tone(raw, bottom, top, "skybox"), skybox_texture=np.array(texture))
        return defaults

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        if self.palette is not None and self.cycle:
            if self.params is not None and "start" in self.params:
                start, episode = self.params["start"], self.params["episode"] + 1
            else:
                start, episode = photometric_start(resolve_source_seed(self.source_seed, self.seed, rng)), 0
            preset = (start + episode) % len(self.palette)
            entry = self.palette[preset]
            return {**{key: np.asarray(entry[key], dtype=np.float64) for key in PALETTE_KEYS},
                    "start": start, "episode": episode, "preset": preset}
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
            _write_two_tone(scene, defaults, "grid", params["grid_rgb1"], params["grid_rgb2"], self.rebuild_textures)
        if "skybox" in self.parts:
            if "skybox_alphas" in defaults:
                _write_gradient(scene, defaults, params["skybox_rgb"])
            else:
                _write_two_tone(scene, defaults, "skybox", defaults["skybox_bottom"], params["skybox_rgb"], self.rebuild_textures)

    def extra_repr(self) -> str:
        option = "dmcgb2_colors" if self.cycle else "palette"
        source = f"{option}={self.palette_source!s}" if self.palette is not None else f"scale={self.scale}"
        rebuild = ", rebuild_textures=True" if self.rebuild_textures and not self.cycle else ""
        seed = "" if self.source_seed is None else f", source_seed={self.source_seed}"
        return f"{source}, parts={self.parts}{rebuild}{seed}"


def _load_dmcgb2_colors(path: str | os.PathLike, file_name: str | None) -> list[dict[str, np.ndarray]]:
    """DMC-GB2's colour presets from ``path`` (or ``path / file_name`` for a folder), read without running code."""
    path = os.path.expanduser(path)
    if os.path.isdir(path):
        if file_name is None:
            raise ValueError(f"RandomSceneColors: dmcgb2_colors={path} is a folder; pass the preset file itself, or "
                             "dmcgb2_file='color_easy.pt' / 'color_hard.pt' (the DMC-GB2 levels set it).")
        path = os.path.join(path, file_name)
    if not os.path.isfile(path):
        raise FileNotFoundError(
            f"DMC-GB2 colour presets {path} do not exist. vigen does not download them: copy envs/dmcgb/data/color_easy.pt "
            "(color_easy, color_video_easy) and color_hard.pt (color_hard, color_video_hard) from aalmuzairee/dmcgb2 and pass "
            "their folder, e.g. level_options={'dmcgb2_colors': '/data/dmcgb2/envs/dmcgb/data'}, or one file's path."
        )
    return load_dmcgb_palette(path)


def _keep_edge_marks(grid: Defaults, raw: np.ndarray, height: int, width: int) -> Defaults:
    """Add the texture's outermost rows and columns to the kept pixels when they hold one colour (MuJoCo's edge marks)."""
    ring = np.flatnonzero(edge_ring(int(height), int(width)))
    if len(np.unique(raw[ring], axis=0)) != 1:
        return grid
    keep = np.union1d(grid["grid_keep"], ring)
    return {**grid, "grid_keep": keep, "grid_kept": raw[keep].copy()}


def _gradient_skybox(raw: np.ndarray, width: int, height: int, top: np.ndarray, bottom: np.ndarray) -> Defaults | None:
    """The weights of MuJoCo's gradient skybox, its top colour and its marks, if the texture is one it rebuilds exactly."""
    if height != CUBE_FACES * width:
        return None
    alphas = cube_gradient_alphas(int(width))
    if not bottom.any():
        top = fit_gradient_top(alphas, raw)
        if top is None:
            return None
    off = (cube_gradient(alphas, top, bottom).reshape(-1, 3) != raw).any(axis=1)
    if off.mean() > 0.05:  # MuJoCo's random marks cover about 1% of a skybox
        return None
    keep = np.flatnonzero(off)
    return {"skybox_alphas": alphas, "skybox_rgb": top, "skybox_keep": keep, "skybox_kept": raw[keep].copy()}


def _write_gradient(scene: SceneHandle, defaults: Defaults, top: np.ndarray) -> None:
    texture = int(defaults["skybox_texture"])
    colors = cube_gradient(defaults["skybox_alphas"], top, defaults["skybox_bottom"]).reshape(-1, 3)
    colors[defaults["skybox_keep"]] = defaults["skybox_kept"]
    texture_pixels(scene.model, texture)[:] = colors.reshape(-1)
    scene.upload_texture(texture)


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


def _write_two_tone(scene: SceneHandle, defaults: Defaults, name: str, low: np.ndarray, high: np.ndarray,
                    as_mujoco: bool = False) -> None:
    texture = int(defaults[f"{name}_texture"])
    t, keep = defaults[f"{name}_t"], defaults[f"{name}_keep"]
    if as_mujoco:  # (1 - t)·low + t·high is exactly low / high at t = 0 / 1, then MuJoCo's truncation to bytes
        weight = t.double().numpy()
        colors = to_bytes((1 - weight) * np.asarray(low, dtype=np.float64) + weight * np.asarray(high, dtype=np.float64))
    else:
        low, high = (torch.from_numpy(255 * c).float() for c in (low, high))
        colors = torch.lerp(low, high, t).round_().to(torch.uint8).numpy()  # lerp is exact at t = 0 and 1
    colors[keep] = defaults[f"{name}_kept"]
    texture_pixels(scene.model, texture)[:] = colors.reshape(-1)
    scene.upload_texture(texture)
