"""DMC-GB2's geometric shifts: camera rotate / shift / rotate_shift presets, cycled one per episode.

Source: aalmuzairee/dmcgb2, ``envs/dmcgb/dmcgb_geometric.py`` and ``envs/dmcgb/dmcgb_wrapper.py`` (commit 5fd8fd7a).
Paper: Almuzairee et al., "A Recipe for Unbounded Data Augmentation in Visual Reinforcement Learning" (DMC-GB2),
https://arxiv.org/abs/2405.17416.
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation
from vigen.transforms.scene.dmcgb2_seed import NUM_PRESETS, check_source_seed, resolve_source_seed
from vigen.transforms.scene.distracting import (
    CAMERA_FIELDS,
    camera_frame,
    resolve_camera,
    rotation_x,
    rotation_y,
    rotation_z,
    write_camera,
)

MODES = ("rotate", "shift", "rotate_shift")
DIFFICULTIES = ("easy", "hard")
# ShiftWrapper._get_corner_coordinates: cam_edges, degrees, as (max_roll, min_roll, max_pitch, min_pitch). The source
# then unpacks each preset as (yaw, pitch, roll): the "roll" pair turns the camera about its own y axis (left / right),
# the "pitch" pair about its own x axis (up / down).
CAM_EDGES = MappingProxyType({
    "walker": (10.0, -10.0, 10.0, -10.0),
    "cheetah": (10.0, -10.0, 10.0, -10.0),
    "cartpole": (8.0, -8.0, 10.0, -10.0),
    "finger": (6.0, -6.0, 12.0, -6.0),
    "ball_in_cup": (6.0, -6.0, 12.0, -6.0),
})
EASY_DIVISOR = 1.5  # shift_easy divides every edge by 1.5
# RotateWrapper._get_rotation_angles: bound_angles [-180, 180], halved for easy
ROTATE_BOUNDS_DEG = MappingProxyType({"easy": (-90.0, 90.0), "hard": (-180.0, 180.0)})
DOMAIN_ALIASES = MappingProxyType({"cup": "ball_in_cup"})  # dmcgb_wrapper.make's name mapping


def _check_difficulty(difficulty: str) -> None:
    if difficulty not in DIFFICULTIES:
        raise ValueError(f"difficulty must be one of {DIFFICULTIES}, got {difficulty!r}.")


def _domain(domain: str | None) -> str:
    name = DOMAIN_ALIASES.get(domain, domain)
    if name not in CAM_EDGES:
        raise ValueError(f"DMC-GB2's shift limits exist for the domains {tuple(CAM_EDGES)} (or 'cup'), got domain={domain!r}.")
    return name


def rotate_presets(difficulty: str) -> np.ndarray:
    """DMC-GB2's 100 rotation angles in degrees, before shuffling: ``lo + i·(hi - lo)/100``, ``i = 0..99``.

    Examples:
        >>> rotate_presets("hard")[:3].round(6).tolist(), rotate_presets("easy")[-1].round(6).item()
        ([-180.0, -176.4, -172.8], 88.2)
    """
    _check_difficulty(difficulty)
    low, high = ROTATE_BOUNDS_DEG[difficulty]
    return np.arange(NUM_PRESETS) * ((high - low) / NUM_PRESETS) + low


def shift_presets(domain: str, difficulty: str) -> np.ndarray:
    """DMC-GB2's 100 shifts ``[100, 2]`` in degrees (turn about the camera's y axis, about its x axis), before shuffling.

    The four corners ``(min_roll, min_pitch) → (max_roll, min_pitch) → (max_roll, max_pitch) → (min_roll, max_pitch)``
    of ``CAM_EDGES[domain]`` (divided by 1.5 for easy), 25 evenly spaced points along each edge of that loop.

    Examples:
        >>> shift_presets("walker", "hard")[[0, 25, 50, 75]].tolist()
        [[-10.0, -10.0], [10.0, -10.0], [10.0, 10.0], [-10.0, 10.0]]
    """
    _check_difficulty(difficulty)
    max_roll, min_roll, max_pitch, min_pitch = np.array(CAM_EDGES[_domain(domain)])
    if difficulty == "easy":
        max_roll, min_roll, max_pitch, min_pitch = np.array([max_roll, min_roll, max_pitch, min_pitch]) / EASY_DIVISOR
    corners = np.array([[min_roll, min_pitch], [max_roll, min_pitch], [max_roll, max_pitch], [min_roll, max_pitch]])
    per_edge = NUM_PRESETS // 4
    steps = np.arange(per_edge)[:, None]
    return np.concatenate([corners[i] + steps * (corners[(i + 1) % 4] - corners[i]) / per_edge for i in range(4)])


def preset_order(seed: int) -> np.ndarray:
    """The order DMC-GB2 plays its presets in for an env seeded ``seed``: ``np.random.RandomState(seed)``'s shuffle.

    Examples:
        >>> preset_order(0)[:5].tolist()
        [26, 86, 2, 55, 75]
    """
    return np.random.RandomState(seed).permutation(NUM_PRESETS)


class DMCGB2Camera(ScenePerturbation):
    """DMC-GB2's camera shifts: ``rotate``, ``shift`` or ``rotate_shift`` at ``easy`` / ``hard``, one preset per episode.

    The camera keeps its position and turns about its own axes: its rotation ``R0`` becomes
    ``R0 · S · Rz(θ)`` with

    * rotate: ``θ`` from 100 evenly spaced angles ``-180 + 3.6·i`` degrees (hard) or ``-90 + 1.8·i``
      (easy): a rotation about the view axis, i.e. the image turns (the source calls it yaw);
    * shift: ``S = Ry(a) · Rx(b)`` from 100 points evenly spaced around the rectangle of
      :data:`CAM_EDGES` (per domain; easy divides it by 1.5), which slides the agent towards the
      image's edges and corners (:func:`shift_presets`);
    * rotate_shift: both, preset ``i`` of each list together (DMC-GB2 shuffles both lists with the same seed).

    The presets are shuffled once with ``np.random.RandomState(s).shuffle`` and episode ``k``
    plays preset ``order[k mod 100]``, as DMC-GB2 does with its env seed ``s`` (:func:`preset_order`;
    ``dmcgb_geometric.py:15, 25, 125, 130``). ``s`` is the seed of the vigen env the transform sits in
    (``make_env(..., seed=s)`` or ``env.set_seed(s)``), recovered from the transform's own seed
    (:func:`~vigen.transforms.scene.dmcgb2_seed.env_seed_of`), so a vigen env and a DMC-GB2 env with the
    same seed show the same presets in the same order; ``source_seed`` sets ``s`` directly. Without
    any seed, ``s`` is drawn from the transform's generator.

    DMC-GB2 overwrites the data's ``cam_xmat[0]`` after each step; vigen writes the same rotation
    into the model field the camera's mode reads (``cam_quat`` fixed, ``cam_mat0`` track /
    trackcom), so the pose holds for every render.

    Source: aalmuzairee/dmcgb2 ``envs/dmcgb/dmcgb_geometric.py`` (ShiftWrapper, RotateWrapper) and
    ``envs/dmcgb/dmcgb_wrapper.py`` (commit 5fd8fd7a). Paper: https://arxiv.org/abs/2405.17416.

    Args:
        mode: ``"rotate"``, ``"shift"`` or ``"rotate_shift"``.
        difficulty: ``"easy"`` or ``"hard"``.
        domain: dm_control domain, for the shift limits (needed by ``shift`` modes): one of
            :data:`CAM_EDGES` (``"cup"`` means ``"ball_in_cup"``).
        camera: camera id or name (DMC-GB2: camera 0).
        source_seed: DMC-GB2's env seed, which seeds the shuffle; ``None``: the seed of the vigen env
            this transform sits in (``seed // 1_000_003``, see above).
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import DMCGB2Camera
        >>> camera = DMCGB2Camera("rotate_shift", "hard", domain="walker", seed=0)
        >>> env = make_env("dmc/walker-walk", generalization=[camera], image_size=32)
        >>> env.reset()["pixels"].shape, camera.params["preset"]
        (torch.Size([9, 32, 32]), 26)
    """

    def __init__(
        self,
        mode: str = "rotate",
        difficulty: str = "hard",
        domain: str | None = None,
        camera: int | str = 0,
        source_seed: int | None = None,
        seed: int | None = None,
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"DMCGB2Camera: mode must be one of {MODES}, got {mode!r}.")
        _check_difficulty(difficulty)
        if "shift" in mode:
            _domain(domain)
        elif domain is not None and not isinstance(domain, str):
            raise TypeError(f"DMCGB2Camera: domain is a dm_control domain name, got {domain!r}.")
        if not isinstance(camera, (int, str)) or isinstance(camera, bool):
            raise TypeError(f"DMCGB2Camera: camera is a camera id (int) or name (str), got {camera!r}.")
        source_seed = check_source_seed(source_seed, "DMCGB2Camera")
        super().__init__(seed=seed)
        self.source_seed = source_seed
        self.mode, self.difficulty, self.domain, self.camera = mode, difficulty, domain, camera

    def rotations(self) -> np.ndarray:
        """``[100, 3, 3]``: the camera-frame rotation of each preset, in the source's (unshuffled) order."""
        mats = np.repeat(np.eye(3)[None], NUM_PRESETS, axis=0)
        if "shift" in self.mode:
            shifts = np.radians(shift_presets(self.domain, self.difficulty))
            mats = np.stack([rotation_y(a) @ rotation_x(b) for a, b in shifts])
        if "rotate" in self.mode:
            mats = np.stack([m @ rotation_z(math.radians(t)) for m, t in zip(mats, rotate_presets(self.difficulty))])
        return mats

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        camera = resolve_camera(model, self.camera)
        mode, position, rotation = camera_frame(model, camera)
        saved = {name: getattr(model, name)[camera].copy() for name in CAMERA_FIELDS[mode]}
        return {"camera": np.array(camera), "mode": np.array(mode), "position": position, "rotation": rotation,
                "presets": self.rotations(), **saved}

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        if self.params is not None and "order_seed" in self.params:
            order_seed, episode = self.params["order_seed"], self.params["episode"] + 1
        else:
            order_seed = resolve_source_seed(self.source_seed, self.seed, rng)
            episode = 0
        preset = int(preset_order(order_seed)[episode % NUM_PRESETS])
        return {"order_seed": order_seed, "episode": episode, "preset": preset}

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {"preset": None}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        model, camera, mode = scene.model, int(defaults["camera"]), int(defaults["mode"])
        if params["preset"] is None:
            for name in CAMERA_FIELDS[mode]:
                getattr(model, name)[camera] = defaults[name]
            return
        rotation = defaults["rotation"] @ defaults["presets"][params["preset"]]
        write_camera(model, camera, mode, defaults["position"], rotation)

    def extra_repr(self) -> str:
        domain = "" if self.domain is None else f", domain={self.domain!r}"
        camera = "" if self.camera == 0 else f", camera={self.camera!r}"
        source = "" if self.source_seed is None else f", source_seed={self.source_seed}"
        return f"mode={self.mode!r}, difficulty={self.difficulty!r}{domain}{camera}{source}"
