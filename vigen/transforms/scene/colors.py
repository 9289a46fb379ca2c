"""DMC-GB's colour shifts: floor grid, skybox and the agent's body, recoloured in the live model."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
import torch

from vigen.assets.palettes import (DMCGB_PRESETS, PALETTE_KEYS, check_palette, dmcgb_preset_file_part, dmcgb_presets,
                                   load_dmcgb_palette)
from vigen.datasets.identity import DataIdentity
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
from vigen.transforms.scene.rlvigen_draws import RLViGenDraws, check_draws

PARTS = ("grid", "skybox", "self")

STATISTICS = "statistics"
"""The palette name of the statistics-matched stand-in colours (default + N(0, scale²) per channel)."""

PALETTE_NAMES = (*DMCGB_PRESETS, STATISTICS)
"""The named palettes: DMC-GB's shipped ``color_easy`` / ``color_hard`` presets and the statistics draw."""

DRAWS = ("dmcgb", "dmcgb2")
"""How presets are chosen per episode: DMC-GB's draw per reset, or DMC-GB2's cycle from a seeded start."""

_PALETTE_CHOICES = ("'color_easy' / 'color_hard' (DMC-GB's presets, shipped), 'statistics' (stand-in colours, default + "
                    "N(0, scale²)), a color_*.pt file or its folder, or a list of preset entries")


class RandomSceneColors(ScenePerturbation):
    """Recolour the floor grid, the skybox and the agent's ``self`` material once per episode (DMC-GB).

    DMC-GB draws one of 100 presets per episode and reloads the physics from rewritten XML;
    vigen edits the live model instead (material colour, and the texture pixels of the grid and
    the skybox, re-uploaded to the render context), which gives the same colours without a
    recompile. ``palette`` says where the colours come from:

    * ``"color_easy"`` / ``"color_hard"``: DMC-GB's own 100 presets, which ship with vigen
      (:func:`~vigen.assets.palettes.dmcgb_presets`; the defaults of the ``color_*`` levels).
    * a DMC-GB / DMC-GB2 preset file (``color_*.pt``; or the folder holding it, read at
      ``dmcgb2_file``), or a list of its entries.
    * ``"statistics"`` (the default; ``None`` is the same): stand-in colours drawn the way the
      presets were made (measured from DMC-GB's files): each channel of ``grid_rgb1``,
      ``skybox_rgb`` and ``self_rgb`` is its default plus N(0, ``scale``²), clipped to [0, 1], and
      ``grid_rgb2 = grid_rgb1 + 0.1`` (the default offset). ``scale`` is 0.1 for ``color_easy``
      and 0.2 for ``color_hard``.

    ``draw`` says which preset each episode shows. ``"dmcgb"`` (the default) draws as DMC-GB's
    ``ColorWrapper`` (``src/env/wrappers.py``): one ``np.random.RandomState(s)`` per env, seeded
    with the env seed ``s``, and ``randint(len(presets))`` at every reset, the first included.
    ``"dmcgb2"`` cycles as DMC-GB2 does (``dmcgb_photometric.py:53, 58, 176-179``): episode ``k``
    shows preset ``(start + k) % len(presets)`` with ``start = np.random.RandomState(s).randint(100)``.
    Either way ``s`` is the seed of the vigen env the transform sits in (or ``source_seed``; see
    :mod:`~vigen.transforms.scene.dmcgb2_seed`), so a vigen env and a DMC-GB (DMC-GB2) env seeded
    alike show the same presets in the same episodes. RL-ViGen's ``background`` colour and
    ``objects_color`` draw as DMC-GB does (``envs/DMCVGB/dmcvgb/wrappers.py:45-56``), from the one
    ``RandomState(s)`` its ``ColorWrapper`` also draws textures and lights from: with several of
    its knobs on, ``rlvigen_draws`` (:class:`~vigen.transforms.scene.rlvigen_draws.RLViGenDraws`)
    names them, and each reset replays all their draws in RL-ViGen's order and shows its own. ``dmcgb2_colors`` (a user's DMC-GB2 file,
    folder or entries) takes the place of a named palette and implies ``draw="dmcgb2"``. The
    statistics draw has no presets: it ignores ``draw``.

    Texture edits keep each texture's structure: the checker's two tones and the sky gradient's
    two ends are mapped to the new colours, and the sky's white stars stay white. With
    ``rebuild_textures`` (implied by ``draw="dmcgb2"``; the ``color_*`` levels set it) the pixels
    are those MuJoCo builds from the new colours when DMC-GB / DMC-GB2 recompile the XML
    (:mod:`~vigen.transforms.scene.builtin_textures`): colours become bytes by truncation, the
    grid's edge marks keep their ``markrgb`` (neither source edits it), and the sky is MuJoCo's
    gradient recomputed for the new top colour; a texture that is not MuJoCo's builtin checker /
    gradient keeps the tone mapping.

    :attr:`data_source` names what the transform shows (for evaluation rows) and
    :attr:`uses_stand_in` is True when ``palette="statistics"`` is asked for by name, i.e. where
    the statistics-matched draw stands in for DMC-GB's presets. Without a palette (the default:
    vigen's colour factors) random colours are the factor's own definition, not a stand-in.
    :meth:`episode_data` names the preset an episode shows.

    Paper: DMC-GB / SODA, https://arxiv.org/abs/2011.13389.

    Args:
        scale: standard deviation of the colour noise of the statistics draw (ignored with presets).
        palette: ``"color_easy"`` / ``"color_hard"`` (shipped DMC-GB presets), ``"statistics"``
            (or ``None``), a preset file or folder, or a list of preset entries.
        parts: which of ``"grid"``, ``"skybox"``, ``"self"`` to recolour (RL-ViGen's
            ``objects_color`` is ``("self",)``).
        rebuild_textures: write the textures MuJoCo builds for the new colours (see above).
        dmcgb2_colors: DMC-GB2 preset file or entries, cycled from a seeded start (in place of a
            named palette); or DMC-GB2's data folder (``envs/dmcgb/data``), read at ``dmcgb2_file``.
        dmcgb2_file: the preset file to read in a folder given as ``dmcgb2_colors`` or ``palette``
            (the levels set ``color_easy.pt`` or ``color_hard.pt``, so one folder serves every colour level).
        source_seed: the source env's seed (DMC-GB's or DMC-GB2's) for the preset draw; ``None``:
            the vigen env's seed.
        draw: ``"dmcgb"`` (DMC-GB's draw per reset) or ``"dmcgb2"`` (DMC-GB2's cycle); ``None``:
            ``"dmcgb2"`` with ``dmcgb2_colors``, else ``"dmcgb"``.
        rlvigen_draws: the knobs of RL-ViGen's config that draw from the same ``RandomState`` at each
            reset (``draw="dmcgb"`` with a palette): its ``background`` (this transform, unless
            ``parts=("self",)``) or ``objects`` colour, and the others, replayed in RL-ViGen's order.
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import RandomSceneColors
        >>> colors = RandomSceneColors(palette="color_hard", rebuild_textures=True, seed=0)
        >>> colors
        RandomSceneColors(palette='color_hard', parts=('grid', 'skybox', 'self'), rebuild_textures=True, seed=0)
        >>> colors.data_source, colors.uses_stand_in
        ('dmcgb-colors/color_hard: 100 of 100, shipped', False)
        >>> env = make_env("dmc/walker-walk").append_transform(colors)
        >>> env.reset()["pixels"].shape
        torch.Size([9, 84, 84])
        >>> RandomSceneColors(palette="statistics", scale=0.2).data_source
        'statistics-matched stand-in colours (scale=0.2)'
        >>> RandomSceneColors(scale=0.2).data_source, RandomSceneColors(scale=0.2).uses_stand_in
        ('random colours: default + N(0, 0.2²) per channel', False)
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
        draw: str | None = None,
        rlvigen_draws: RLViGenDraws | None = None,
        seed: int | None = None,
    ) -> None:
        unknown = set(parts) - set(PARTS)
        if unknown:
            raise ValueError(f"Unknown parts {sorted(unknown)}; choose from {PARTS}.")
        if draw is not None and draw not in DRAWS:
            raise ValueError(f"RandomSceneColors: unknown draw {draw!r}; choose 'dmcgb' (DMC-GB: one preset drawn per reset "
                             "from RandomState(env seed)) or 'dmcgb2' (DMC-GB2: presets cycled from a seeded start).")
        self.stands_in = isinstance(palette, str) and palette == STATISTICS  # asked for in place of the presets
        palette = STATISTICS if palette is None else palette
        named = isinstance(palette, str) and palette in PALETTE_NAMES
        if isinstance(palette, str) and not named and not _looks_like_a_path(palette):
            raise ValueError(f"RandomSceneColors: unknown palette {palette!r}; choose {_PALETTE_CHOICES}.")
        if dmcgb2_colors is not None:
            if not named:
                raise ValueError("RandomSceneColors: palette (a preset file or entries) and dmcgb2_colors (DMC-GB2's presets) "
                                 "both give the colours; pass one of them (palette=<file>, draw='dmcgb2' cycles a file "
                                 "as DMC-GB2 does).")
            if draw == "dmcgb":
                raise ValueError("RandomSceneColors: dmcgb2_colors are cycled as DMC-GB2 cycles them; draw='dmcgb' contradicts "
                                 "it. Pass palette=<file> to draw a file's presets as DMC-GB does.")
            palette, draw, named = dmcgb2_colors, "dmcgb2", False
        if not isinstance(rebuild_textures, bool):
            raise TypeError(f"RandomSceneColors: rebuild_textures is True or False, got {rebuild_textures!r}.")
        source_seed = check_source_seed(source_seed, "RandomSceneColors")
        super().__init__(seed=seed)
        self.source_seed = source_seed
        self.scale = scale
        self.from_dmcgb2_colors = dmcgb2_colors is not None
        self.palette_name = palette if named and palette != STATISTICS else None
        if isinstance(palette, str) and palette == STATISTICS:
            self.palette, self.palette_source = None, None
        elif named:
            self.palette, self.palette_source = dmcgb_presets(palette), palette
        elif isinstance(palette, (str, os.PathLike)):
            option = "dmcgb2_colors" if self.from_dmcgb2_colors else "palette"
            self.palette_source = _preset_file(palette, dmcgb2_file, option)
            self.palette = load_dmcgb_palette(self.palette_source)
        else:  # entries given in code: checked now, not at the first reset
            option = "dmcgb2_colors" if self.from_dmcgb2_colors else "palette"
            self.palette = check_palette(list(palette) if isinstance(palette, Sequence) else palette,
                                         f"RandomSceneColors({option}=...)")
            self.palette_source = "entries"
        self.draw = (draw or "dmcgb") if self.palette is not None else None
        self.cycle = self.draw == "dmcgb2"
        self.rebuild_textures = rebuild_textures or self.cycle
        self.parts = tuple(parts)
        self.knob = "objects" if self.parts == ("self",) else "background"
        self.rlvigen_draws = check_draws(rlvigen_draws, self.knob, "RandomSceneColors")
        if self.rlvigen_draws is not None and self.draw != "dmcgb":
            raise ValueError("RandomSceneColors: rlvigen_draws replays RL-ViGen's draws of the presets (DMC-GB's draw per reset); "
                             "it needs a palette and draw='dmcgb'.")
        self._source_rng: np.random.RandomState | None = None

    @property
    def uses_stand_in(self) -> bool:
        """True when the statistics-matched colours were asked for in place of a benchmark's presets (``palette="statistics"``)."""
        return self.palette is None and self.stands_in

    @property
    def data_source(self) -> str:
        """What the colours are, by identity (never a path), e.g. ``"dmcgb-colors/color_hard: 100 of 100, shipped"``.

        DMC-GB's presets as shipped name the data set part (``dmcgb-colors/color_hard``) and
        ``shipped``; a user's preset file that is DMC-GB's own (its git blob id the pinned one) is
        ``verified``; any other is ``user file: <n> presets``.
        """
        if self.palette is None:
            if not self.stands_in:
                return f"random colours: default + N(0, {self.scale}²) per channel"
            return f"statistics-matched stand-in colours (scale={self.scale})"
        count = len(self.palette)
        cycled = "cycled as DMC-GB2 does" if self.cycle else ""
        if self.palette_name is not None:
            return str(DataIdentity("dmcgb-colors", self.palette_name, count, count, "shipped", note=cycled))
        part = None if self.palette_source == "entries" else dmcgb_preset_file_part(self.palette_source)
        if part is not None:  # a copy of DMC-GB's own file: its git blob id is the pinned one
            return str(DataIdentity("dmcgb-colors", part, count, count, "verified", note=cycled))
        return str(DataIdentity(None, None, count, None, "user", kind="presets",
                                where="files" if self.palette_source == "entries" else "file",
                                note=", ".join(filter(None, ["given in code" if self.palette_source == "entries" else "",
                                                             cycled]))))

    def episode_data(self) -> dict[str, Any]:
        """The preset this episode shows (its index in the palette), or nothing for random colours.

        Examples:
            >>> RandomSceneColors(palette="color_hard").episode_data()  # before the first reset
            {}
        """
        return {"preset": int(self.params["preset"])} if self.params is not None and "preset" in self.params else {}

    def set_seed(self, seed: int | None) -> None:
        super().set_seed(seed)
        self._source_rng = None  # DMC-GB's draws restart, as in a DMC-GB env built with the new seed

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        defaults: Defaults = {"nlight": np.array(model.nlight)}
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
            return {**self._preset(preset), "start": start, "episode": episode}
        if self.palette is not None:
            if self._source_rng is None:
                self._source_rng = np.random.RandomState(resolve_source_seed(self.source_seed, self.seed, rng))
            if self.rlvigen_draws is not None:
                return self._preset(self.rlvigen_draws.episode(self._source_rng, int(defaults["nlight"]))[self.knob])
            return self._preset(int(self._source_rng.randint(len(self.palette))))
        params = {key: np.clip(defaults[key] + rng.normal(0, self.scale, 3), 0, 1) for key in PALETTE_KEYS
                  if key in defaults and key != "grid_rgb2"}
        if "grid_rgb1" in params:
            params["grid_rgb2"] = np.clip(params["grid_rgb1"] + defaults["grid_rgb2"] - defaults["grid_rgb1"], 0, 1)
        return params

    def _preset(self, index: int) -> SceneParams:
        entry = self.palette[index]
        return {**{key: np.asarray(entry[key], dtype=np.float64) for key in PALETTE_KEYS}, "preset": index}

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
        if self.palette is None:
            source = ("palette='statistics', " if self.stands_in else "") + f"scale={self.scale}"
        elif self.from_dmcgb2_colors:
            source = f"dmcgb2_colors={self.palette_source!s}"
        else:
            name = repr(self.palette_name) if self.palette_name is not None else str(self.palette_source)
            source = f"palette={name}" + (", draw='dmcgb2'" if self.cycle else "")
        rebuild = ", rebuild_textures=True" if self.rebuild_textures and not self.cycle else ""
        seed = "" if self.source_seed is None else f", source_seed={self.source_seed}"
        draws = "" if self.rlvigen_draws is None else f", rlvigen_draws={self.rlvigen_draws!r}"
        return f"{source}, parts={self.parts}{rebuild}{seed}{draws}"


def _looks_like_a_path(text: str) -> bool:
    """A string that names a file or folder (a separator, a suffix, ``~``, or something that exists), not a misspelled name."""
    return os.sep in text or "/" in text or "." in text or text.startswith("~") or os.path.exists(text)


def _preset_file(path: str | os.PathLike, file_name: str | None, option: str) -> str:
    """The preset file at ``path`` (or ``path / file_name`` for a folder), or an error naming what to pass instead."""
    path = os.path.expanduser(os.fspath(path))
    if os.path.isdir(path):
        if file_name is None:
            raise ValueError(f"RandomSceneColors: {option}={path} is a folder; pass the preset file itself, or "
                             "dmcgb2_file='color_easy.pt' / 'color_hard.pt' (the colour levels set it).")
        path = os.path.join(path, file_name)
    if not os.path.isfile(path):
        raise FileNotFoundError(
            f"RandomSceneColors: the preset file {path} ({option}=) does not exist. DMC-GB's presets ship with vigen: "
            f"palette='color_easy' / 'color_hard' (draw='dmcgb2' cycles them as DMC-GB2 does) need no file. For your own "
            f"copy, pass a color_*.pt file or its folder, e.g. level_options={{{option!r}: '/data/dmcgb2/envs/dmcgb/data'}}. "
            f"Palette choices: {_PALETTE_CHOICES}."
        )
    return path


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
