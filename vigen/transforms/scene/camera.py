"""Camera shifts: position offsets (RL-ViGen), orientation and field of view (Distracting Control Suite scales)."""

from __future__ import annotations

import mujoco
import numpy as np

from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation

# MuJoCo reads a camera's pose from a different field per mode (fixed, track, trackcom...).
POSITION_FIELDS = ("cam_pos", "cam_pos0", "cam_poscom0")


class RandomCamera(ScenePerturbation):
    """Move, turn and zoom every camera once per episode; the view then stays fixed for the episode.

    * position: each coordinate offset by U(±``position``) (RL-ViGen's DMC ``cam_pos``: 0.08 easy,
      0.15 hard);
    * orientation: a rotation about the camera's own axes by roll, pitch and yaw each U(±
      ``rotation_deg``) (the Distracting Control Suite's ``π/2 · scale``: 9° at its easy scale 0.1,
      27° at hard 0.3);
    * field of view: ``fovy`` plus U(``fov_deg``) (RL-ViGen's Adroit ranges: [-4, 5]° easy,
      [-10, 10]° hard).

    RL-ViGen draws the camera offset once per env and moves only the position; vigen redraws per
    episode, from ``seed``, so episodes with different seeds see different views.

    Papers: RL-ViGen, https://arxiv.org/abs/2307.10224; Distracting Control Suite,
    https://arxiv.org/abs/2101.02722.

    Args:
        position: half-width of the position offset (scene units), or 0.
        rotation_deg: half-width of each rotation angle in degrees, or 0.
        fov_deg: ``(low, high)`` field-of-view change in degrees, or ``None``.
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import RandomCamera
        >>> env = make_env("dmc/walker-walk").append_transform(RandomCamera(position=0.08, rotation_deg=9, seed=0))
        >>> env.reset()["pixels"].shape
        torch.Size([9, 84, 84])
    """

    def __init__(
        self,
        position: float = 0.08,
        rotation_deg: float = 0.0,
        fov_deg: tuple[float, float] | None = None,
        seed: int | None = None,
    ) -> None:
        super().__init__(seed=seed)
        self.position = position
        self.rotation_deg = rotation_deg
        self.fov_deg = tuple(fov_deg) if fov_deg is not None else None

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        if model.ncam == 0:
            raise ValueError("RandomCamera needs a scene with at least one camera.")
        defaults = {name: getattr(model, name).copy() for name in POSITION_FIELDS}
        defaults.update(cam_quat=model.cam_quat.copy(), cam_mat0=model.cam_mat0.copy(), cam_fovy=model.cam_fovy.copy())
        return defaults

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        n = len(defaults["cam_fovy"])
        fov = rng.uniform(*self.fov_deg, size=n) if self.fov_deg is not None else np.zeros(n)
        return {
            "position": rng.uniform(-self.position, self.position, size=(n, 3)),
            "angles": np.deg2rad(rng.uniform(-self.rotation_deg, self.rotation_deg, size=(n, 3))),
            "fov": fov,
        }

    def identity_params(self, defaults: Defaults) -> SceneParams:
        n = len(defaults["cam_fovy"])
        return {"position": np.zeros((n, 3)), "angles": np.zeros((n, 3)), "fov": np.zeros(n)}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        model = scene.model
        for name in POSITION_FIELDS:
            getattr(model, name)[:] = defaults[name] + params["position"]
        for camera, angles in enumerate(params["angles"]):
            turn = np.zeros(4)
            mujoco.mju_euler2Quat(turn, angles, "xyz")  # about the camera's own axes
            quat = np.zeros(4)
            mujoco.mju_mulQuat(quat, defaults["cam_quat"][camera], turn)
            model.cam_quat[camera] = quat
            rotation = np.zeros(9)
            mujoco.mju_quat2Mat(rotation, turn)
            model.cam_mat0[camera] = (defaults["cam_mat0"][camera].reshape(3, 3) @ rotation.reshape(3, 3)).reshape(9)
        model.cam_fovy[:] = defaults["cam_fovy"] + params["fov"]

    def extra_repr(self) -> str:
        return f"position={self.position}, rotation_deg={self.rotation_deg}, fov_deg={self.fov_deg}"
