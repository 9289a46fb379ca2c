"""Colour randomization of named materials and geoms: robosuite's local colour shifts and robot recolouring (RL-ViGen)."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation


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
