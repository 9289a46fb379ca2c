"""Colour randomization of named materials and geoms: robosuite's local colour shifts and robot recolouring (RL-ViGen).

:class:`RandomMaterialColors` draws random colours; :class:`PresetMaterialColors` shifts the robot by the
``self_rgb`` of one of DMC-GB's presets, as RL-ViGen's ``objects_color`` does on its Menagerie robots.
"""

from __future__ import annotations

from collections.abc import Sequence

from typing import Any

import mujoco
import numpy as np

from vigen.assets.palettes import DMCGB_PRESETS, dmcgb_presets
from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation
from vigen.transforms.scene.colors import RandomSceneColors
from vigen.transforms.scene.dmcgb2_seed import check_source_seed, resolve_source_seed
from vigen.transforms.scene.rlvigen_draws import RLViGenDraws, check_draws

RLVIGEN_SELF_ORIGIN = (0.7, 0.5, 0.3)
"""dm_control's ``self`` colour, which RL-ViGen subtracts from a preset's ``self_rgb`` to shift its robots' materials
(``envs/DMCVGB/dm_control/dm_control/suite/common/settings.py:60-65``: ``white`` = ``self_rgb − (0.7, 0.5, 0.3) + 1``,
``dark`` ``+ 0.2``, ``carbonfibre`` ``+ 0.25``, i.e. each material's own colour plus the one offset)."""


class RandomMaterialColors(ScenePerturbation):
    """Recolour materials and uncoloured-by-material geoms, chosen by name, once per episode.

    Each selected material (``mat_rgba``) and each selected geom without a material
    (``geom_rgba``) gets ``rgb = clip((1 - mix) · default + mix · u + δ, 0, 1)`` with ``u ~ U(0, 1)³``
    and ``δ ~ N(0, shift²)³``: its own draws (``shared=False``), or one for all of them
    (``shared=True``). Alpha is kept. A textured material's colour multiplies its texture, so
    textures are tinted, not replaced.

    RL-ViGen's robosuite levels use robosuite's ``TextureModder`` with ``randomize_local``:
    ``rgb = 0.8 · default + 0.2 · u`` on every non-robot geom (``mix=0.2``, ``exclude`` the robot),
    and in ``eval-medium`` one uniform colour for the whole robot and gripper (``mix=1``,
    ``shared=True``, ``include`` the robot). (The modder's checker, noise and gradient texture
    variants are not reproduced: vigen keeps each texture and tints it.)

    Paper: RL-ViGen, https://arxiv.org/abs/2307.10224 (robosuite presets from SECANT,
    https://arxiv.org/abs/2106.09678).

    Args:
        mix: weight of the random colour, 0 (unchanged) to 1 (fully random).
        include: name prefixes of the materials and geoms to recolour; ``None`` selects all.
        exclude: name prefixes never recoloured (applied after ``include``).
        shift: standard deviation of a colour offset added to every channel (0: none).
        shared: one random colour (and offset) for every selected part instead of one each.
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import RandomMaterialColors
        >>> env = make_env("dmc/walker-walk").append_transform(RandomMaterialColors(mix=0.5, include=("self",), seed=0))
        >>> env.reset()["pixels"].shape
        torch.Size([9, 84, 84])
    """

    def __init__(
        self,
        mix: float = 0.2,
        include: Sequence[str] | None = None,
        exclude: Sequence[str] = (),
        shared: bool = False,
        shift: float = 0.0,
        seed: int | None = None,
    ) -> None:
        if not 0.0 <= mix <= 1.0:
            raise ValueError(f"mix is the weight of the random colour, between 0 and 1; got {mix}.")
        if not shift >= 0.0:
            raise ValueError(f"shift is the standard deviation of a colour offset, >= 0; got {shift}.")
        super().__init__(seed=seed)
        self.mix = mix
        self.include = tuple(include) if include is not None else None
        self.exclude = tuple(exclude)
        self.shared = shared
        self.shift = float(shift)

    def _selected(self, model: object, kind: mujoco.mjtObj, count: int) -> np.ndarray:
        names = [mujoco.mj_id2name(model, kind, i) or "" for i in range(count)]
        return np.array([i for i, name in enumerate(names)
                         if (self.include is None or name.startswith(self.include)) and not name.startswith(self.exclude)],
                        dtype=np.int64)

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        materials = self._selected(model, mujoco.mjtObj.mjOBJ_MATERIAL, model.nmat)
        geoms = self._selected(model, mujoco.mjtObj.mjOBJ_GEOM, model.ngeom)
        geoms = geoms[model.geom_matid[geoms] < 0]
        if len(materials) + len(geoms) == 0:
            raise ValueError(f"RandomMaterialColors(include={self.include}, exclude={self.exclude}) selects no material or geom.")
        return {"materials": materials, "geoms": geoms,
                "material_rgb": model.mat_rgba[materials, :3].copy(), "geom_rgb": model.geom_rgba[geoms, :3].copy()}

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        count = len(defaults["materials"]) + len(defaults["geoms"])
        draws = 1 if self.shared else count
        colors = np.repeat(rng.uniform(0, 1, (draws, 3)), count // draws, axis=0)
        params = {"colors": colors}
        if self.shift > 0:
            params["offsets"] = np.repeat(rng.normal(0, self.shift, (draws, 3)), count // draws, axis=0)
        return params

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {"colors": None}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        default = np.concatenate([defaults["material_rgb"], defaults["geom_rgb"]])
        rgb = default if params["colors"] is None else (1 - self.mix) * default + self.mix * params["colors"]
        if params.get("offsets") is not None:
            rgb = np.clip(rgb + params["offsets"], 0.0, 1.0)
        materials = len(defaults["materials"])
        scene.model.mat_rgba[defaults["materials"], :3] = rgb[:materials]
        scene.model.geom_rgba[defaults["geoms"], :3] = rgb[materials:]

    def extra_repr(self) -> str:
        shift = f", shift={self.shift}" if self.shift else ""
        return f"mix={self.mix}, include={self.include}, exclude={self.exclude}, shared={self.shared}{shift}"


class PresetMaterialColors(RandomMaterialColors):
    """Shift named materials by one DMC-GB preset's ``self`` colour offset per episode (RL-ViGen's ``objects_color`` on its robots).

    RL-ViGen draws a preset of DMC-GB's ``color_easy`` / ``color_hard`` per reset
    (``envs/DMCVGB/dmcvgb/wrappers.py:53-56``: ``randint(100)`` from its ``RandomState(seed)``) and writes
    its ``self_rgb`` into the shared materials its Menagerie robots use
    (``suite/common/settings.py:51-65``): ``self`` becomes ``self_rgb``, and ``white``, ``dark`` and
    ``carbonfibre`` become their own colour plus ``self_rgb − (0.7, 0.5, 0.3)``
    (:data:`RLVIGEN_SELF_ORIGIN`, dm_control's ``self``). vigen's robots are other models, so every
    selected part (``include`` / ``exclude``, as :class:`RandomMaterialColors`) gets that one offset:
    ``rgb = default + self_rgb − (0.7, 0.5, 0.3)``, not clipped, as RL-ViGen writes it into the XML
    (MuJoCo lights a colour above 1 brighter than 1, and one below 0 darker than 0).

    The draw is DMC-GB's (:class:`~vigen.transforms.RandomSceneColors`' default): one
    ``np.random.RandomState(s)`` per env, seeded with the env seed ``s`` (or ``source_seed``), and
    ``randint(100)`` at every reset; ``rlvigen_draws`` replays the other knobs' draws of RL-ViGen's
    config in between (:mod:`~vigen.transforms.scene.rlvigen_draws`). :meth:`episode_data` names the
    preset (``objects_preset``).

    Paper: RL-ViGen, https://arxiv.org/abs/2307.10224 (presets from DMC-GB, https://arxiv.org/abs/2011.13389).

    Args:
        palette: ``"color_easy"`` or ``"color_hard"`` (DMC-GB's presets, shipped with vigen).
        include: name prefixes of the materials and geoms to shift.
        exclude: name prefixes never shifted.
        source_seed: RL-ViGen's env seed for the draw; ``None``: the seed of the vigen env this transform sits in.
        rlvigen_draws: the knobs of RL-ViGen's config drawing from the same ``RandomState`` (with ``objects`` on).
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> colors = PresetMaterialColors("color_hard", include=("self",), source_seed=0, seed=0)
        >>> env = make_env("dmc/walker-walk", image_size=32).append_transform(colors)
        >>> _ = env.reset()
        >>> colors.episode_data(), colors.uses_stand_in  # np.random.RandomState(0).randint(100) == 44
        ({'objects_preset': 44}, False)
        >>> colors.data_source.endswith(", self_rgb − (0.7, 0.5, 0.3) on the robot")
        True
    """

    def __init__(
        self,
        palette: str = "color_easy",
        include: Sequence[str] | None = None,
        exclude: Sequence[str] = (),
        source_seed: int | None = None,
        rlvigen_draws: RLViGenDraws | None = None,
        seed: int | None = None,
    ) -> None:
        if palette not in DMCGB_PRESETS:
            raise ValueError(f"PresetMaterialColors: palette is one of DMC-GB's shipped preset lists {DMCGB_PRESETS}, "
                             f"got {palette!r}.")
        super().__init__(mix=0.0, include=include, exclude=exclude, shared=True, seed=seed)
        self.palette_name = palette
        self.palette = dmcgb_presets(palette)
        self.source_seed = check_source_seed(source_seed, "PresetMaterialColors")
        self.rlvigen_draws = check_draws(rlvigen_draws, "objects", "PresetMaterialColors")
        self._source_rng: np.random.RandomState | None = None

    uses_stand_in = False
    """DMC-GB's own presets: never a stand-in."""

    @property
    def data_source(self) -> str:
        """What the colours are: the presets' label (:attr:`RandomSceneColors.data_source`), then how they are shown."""
        return f"{RandomSceneColors(palette=self.palette_name).data_source}, self_rgb − (0.7, 0.5, 0.3) on the robot"

    def episode_data(self) -> dict[str, Any]:
        """The preset this episode shows (its index in the palette)."""
        return {"objects_preset": int(self.params["preset"])} if self.params is not None and "preset" in self.params else {}

    def set_seed(self, seed: int | None) -> None:
        super().set_seed(seed)
        self._source_rng = None  # the draws restart, as in a new RL-ViGen env built with the seed

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        return {**super().read_defaults(scene), "nlight": np.array(scene.model.nlight)}

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        if self._source_rng is None:
            self._source_rng = np.random.RandomState(resolve_source_seed(self.source_seed, self.seed, rng))
        if self.rlvigen_draws is not None:
            preset = self.rlvigen_draws.episode(self._source_rng, int(defaults["nlight"]))["objects"]
        else:
            preset = int(self._source_rng.randint(len(self.palette)))
        offset = np.asarray(self.palette[preset]["self_rgb"], dtype=np.float64) - np.asarray(RLVIGEN_SELF_ORIGIN)
        return {"preset": preset, "offset": offset}

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {"offset": np.zeros(3)}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        scene.model.mat_rgba[defaults["materials"], :3] = defaults["material_rgb"] + params["offset"]
        scene.model.geom_rgba[defaults["geoms"], :3] = defaults["geom_rgb"] + params["offset"]

    def extra_repr(self) -> str:
        seed = "" if self.source_seed is None else f", source_seed={self.source_seed}"
        draws = "" if self.rlvigen_draws is None else f", rlvigen_draws={self.rlvigen_draws!r}"
        return f"palette={self.palette_name!r}, include={self.include}, exclude={self.exclude}{seed}{draws}"
