"""The Distracting Control Suite's camera and colour distractions, static and dynamic, as scene perturbations.

Definitions follow the original suite (google-research/google-research, ``distracting_control/``, commit
0c1bbe5f) and DMC-GB's variant of it (nicklashansen/dmcontrol-generalization-benchmark,
``src/env/distracting_control/``, commit ff9c0aa8), which DMC-GB, SVEA, SGQN and DMC-GB2 evaluate on.
Paper: Stone et al., "The Distracting Control Suite", https://arxiv.org/abs/2101.02722.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from types import MappingProxyType

import mujoco
import numpy as np

from tensordict import TensorDictBase

from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation
from vigen.transforms.scene.schedule import action_repeat_of, check_update_every, updates_due

# DMC-GB's src/env/distracting_control/suite_utils.py: its intensities (the scale itself) and videos per intensity
# (None: every video of the split)
DCS_SCALES = (0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5)
DCS_NUM_VIDEOS = MappingProxyType({0.025: 2, 0.05: 2, 0.1: 4, 0.15: 6, 0.2: 8, 0.3: None, 0.4: None, 0.5: None})
# suite_utils.get_background_kwargs: the floor grid's alpha per domain (every other domain: 0.3)
DCS_GROUND_PLANE_ALPHA = MappingProxyType({"reacher": 0.0, "walker": 1.0, "cheetah": 1.0})
DCS_DEFAULT_GROUND_PLANE_ALPHA = 0.3

# MuJoCo camera modes (mjtCamLight) and the model fields each reads the camera's pose from
CAMERA_FIELDS = MappingProxyType({
    int(mujoco.mjtCamLight.mjCAMLIGHT_FIXED): ("cam_pos", "cam_quat"),
    int(mujoco.mjtCamLight.mjCAMLIGHT_TRACK): ("cam_pos0", "cam_mat0"),
    int(mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM): ("cam_poscom0", "cam_mat0"),
})


def dcs_ground_plane_alpha(domain: str) -> float:
    """The floor grid's alpha the Distracting Control Suite sets with its background videos, per dm_control domain.

    Examples:
        >>> dcs_ground_plane_alpha("walker"), dcs_ground_plane_alpha("reacher"), dcs_ground_plane_alpha("cartpole")
        (1.0, 0.0, 0.3)
    """
    return DCS_GROUND_PLANE_ALPHA.get(domain, DCS_DEFAULT_GROUND_PLANE_ALPHA)


def _check_common(name: str, scale: float, walk_steps: int, update_every: int | None) -> None:
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0.0 <= scale <= 1.0:
        raise ValueError(f"{name}: scale is the suite's intensity s in [0, 1] (DCS_SCALES lists DMC-GB's), got {scale!r}.")
    if isinstance(walk_steps, bool) or not isinstance(walk_steps, int) or walk_steps < 1:
        raise ValueError(f"{name}: walk_steps is the number of random-walk steps per env step, an int >= 1; got {walk_steps!r}.")
    check_update_every(name, update_every)
    if update_every is not None and walk_steps != 1:
        raise ValueError(f"{name}: walk_steps={walk_steps} and update_every={update_every} both set the walks per env step; "
                         "pass update_every (walks counted in control steps, as DCS) or walk_steps, not both.")


# -- spherical coordinates and look-at rotations (distracting_control/camera.py's conventions) ------------------------

def to_sphere(point: np.ndarray) -> np.ndarray:
    """``(radius, azimuth, polar)`` of a point: azimuth ``atan2(y, x)``, polar angle from +z."""
    return np.array([math.hypot(*point), math.atan2(point[1], point[0]), math.atan2(math.hypot(point[0], point[1]), point[2])])


def from_sphere(sphere: np.ndarray) -> np.ndarray:
    """The point at ``(radius, azimuth, polar)``."""
    radius, azimuth, polar = sphere
    return radius * np.array([math.sin(polar) * math.cos(azimuth), math.sin(polar) * math.sin(azimuth), math.cos(polar)])


def rotation_x(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotation_y(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rotation_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def look_at_level(target: np.ndarray, position: np.ndarray) -> np.ndarray:
    """Camera rotation (MuJoCo: looks along its -z) from ``position`` towards ``target``, with a level horizon.

    ``Rz(-yaw) · Rx(pitch)``, ``yaw = atan2(dx, dy)``, ``pitch = atan2(dz, |dxy|) + π/2`` for the unit direction ``d``.
    """
    d = (target - position) / np.linalg.norm(target - position)
    yaw = math.atan2(d[0], d[1])
    pitch = math.atan2(d[2], math.hypot(d[0], d[1])) + math.pi / 2
    return rotation_z(-yaw) @ rotation_x(pitch)


def look_at_shortest(target: np.ndarray, position: np.ndarray) -> np.ndarray:
    """The smallest rotation taking the view axis ``(0, 0, -1)`` to the direction from ``position`` to ``target``.

    Unlike :func:`look_at_level` it has no singularity straight above the target (reacher's top-down camera).
    """
    d = (target - position) / np.linalg.norm(target - position)
    axis = np.cross([0.0, 0.0, -1.0], d)
    sin, cos = float(np.linalg.norm(axis)), -float(d[2])
    if sin < 1e-12:
        return np.eye(3) if cos > 0 else rotation_x(math.pi)
    k = axis / sin
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + sin * cross + (1 - cos) * cross @ cross


def camera_frame(model: mujoco.MjModel, camera: int) -> tuple[int, np.ndarray, np.ndarray]:
    """``(mode, position, rotation)`` of a camera in the frame its mode reads it in.

    Fixed: the parent body's frame (``cam_pos``, ``cam_quat``); track: world axes about the body
    (``cam_pos0``, ``cam_mat0``); trackcom: world axes about the body's subtree centre of mass
    (``cam_poscom0``, ``cam_mat0``). Other modes (target body) raise.
    """
    mode = int(model.cam_mode[camera])
    if mode not in CAMERA_FIELDS:
        names = ", ".join(mujoco.mjtCamLight(m).name for m in CAMERA_FIELDS)
        raise ValueError(f"Camera {camera} has mode {mujoco.mjtCamLight(mode).name}; camera distractions support {names}.")
    position_field, rotation_field = CAMERA_FIELDS[mode]
    position = getattr(model, position_field)[camera].copy()
    if rotation_field == "cam_quat":
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, model.cam_quat[camera])
    else:
        rotation = model.cam_mat0[camera].copy()
    return mode, position, rotation.reshape(3, 3)


def write_camera(model: mujoco.MjModel, camera: int, mode: int, position: np.ndarray, rotation: np.ndarray) -> None:
    """Write a camera pose given in the frame of :func:`camera_frame` into the model fields its mode reads."""
    position_field, rotation_field = CAMERA_FIELDS[mode]
    getattr(model, position_field)[camera] = position
    if rotation_field == "cam_quat":
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation).reshape(9))
        model.cam_quat[camera] = quat
    else:
        model.cam_mat0[camera] = rotation.reshape(9)


def resolve_camera(model: mujoco.MjModel, camera: int | str) -> int:
    """A camera id from an id or a name, with a clear error."""
    if isinstance(camera, str):
        index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        if index < 0:
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)]
            raise ValueError(f"The scene has no camera named {camera!r}; its cameras are {names}.")
        return index
    if not 0 <= camera < model.ncam:
        raise ValueError(f"camera={camera} but the scene has {model.ncam} camera(s) (ids 0..{model.ncam - 1}).")
    return int(camera)


class DistractionWalk(ScenePerturbation):
    """Base of the Distracting Control Suite's drifting distractions: how often the random walk steps, and when it shows.

    Subclasses write :meth:`walk` (one random-walk step of ``params``, in place) besides the
    :class:`~vigen.transforms.scene.ScenePerturbation` methods. With ``dynamic``, each env step
    walks ``walk_steps`` times, or, with ``update_every`` set, once per ``update_every``
    control steps counted from the reset (:func:`~vigen.transforms.scene.schedule.updates_due`;
    the env's ``action_repeat`` control steps make one env step). The walks happen before the
    env steps (TorchRL's ``inv`` pass runs before the base env steps and renders), so the frame of
    an env step shows them, as in DCS, whose wrappers move after each control step and whose
    pixel wrapper renders after the last one of the action repeat.

    Args:
        scale: the suite's scale ``s`` in [0, 1].
        dynamic: walk every step.
        walk_steps: random-walk steps per env step, with ``update_every=None``.
        update_every: control steps per walk step (DMC-GB's copy of DCS: 2, the original: 1), or
            ``None`` for ``walk_steps`` per env step whatever the action repeat.
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Paper: https://arxiv.org/abs/2101.02722.

    Examples:
        >>> colors = DistractingColors(0.1, dynamic=True, update_every=2)  # DMC-GB: every 2nd control step
        >>> params = {}
        >>> isinstance(colors, DistractionWalk), [updates_due(params, colors.update_every, 4) for _ in range(2)]
        (True, [2, 2])
    """

    def __init__(self, scale: float, dynamic: bool, walk_steps: int = 1, update_every: int | None = None,
                 seed: int | None = None) -> None:
        _check_common(type(self).__name__, scale, walk_steps, update_every)
        super().__init__(seed=seed)
        self.scale, self.dynamic, self.walk_steps, self.update_every = float(scale), bool(dynamic), walk_steps, update_every

    def walk(self, rng: np.random.Generator, defaults: Defaults, params: SceneParams) -> None:
        raise NotImplementedError

    def walks_due(self, params: SceneParams) -> int:
        """Random-walk steps of the coming env step (counts the control steps in ``params`` with ``update_every``)."""
        if self.update_every is None:
            return self.walk_steps
        return updates_due(params, self.update_every, action_repeat_of(self))

    def advance(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        """One env step's drift: the walk steps due, then the result written into the model."""
        if not self.dynamic:
            return
        rng = self.generator()
        for _ in range(self.walks_due(params)):
            self.walk(rng, defaults, params)
        self.apply(scene, defaults, params)

    def _inv_call(self, tensordict: TensorDictBase) -> TensorDictBase:
        # runs before the base env steps: the walk shows in this step's frame
        if self.params is not None:
            scene = self.scene
            self.advance(scene, self.defaults(scene), self.params)
        return tensordict

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        return next_tensordict

    def schedule_repr(self) -> str:
        walk = f", walk_steps={self.walk_steps}" if self.walk_steps != 1 else ""
        return walk + ("" if self.update_every is None else f", update_every={self.update_every}")


class DistractingCamera(DistractionWalk):
    """The Distracting Control Suite's camera distraction at scale ``s``: a new viewpoint each episode, drifting if dynamic.

    The camera's start position ``p0`` is taken in spherical coordinates ``(r0, h0, v0)`` (azimuth
    ``h = atan2(y, x)``, polar ``v`` from +z) about the origin of the frame its mode reads it in:
    the world (a fixed camera on the world body; the parent body's frame in general) or, for a
    ``trackcom`` camera, the agent's centre of mass (``track``: the body). Each episode draws

    * ``h ~ U(h0 ± π/2·s)``, ``v ~ U(v0 ± π/2·s)``, ``roll ~ U(±π/2·s)``,
      ``r ~ U(r0·(1 - 0.5·s), r0·(1 + 1.5·s))``;
    * with ``limit_to_upper_quadrant`` (DCS: every domain but reacher) ``v ∈ [0, π/2]`` and
      ``h ∈ [-π, 0]`` as well;

    and points the camera at the look-at point ``L = p0 + R0·(0, 0, -d)`` (``d``: distance from
    the camera to the subtree centre of mass of body 1), with a level horizon
    (``Rz(-yaw)·Rx(pitch)``; without the quadrant limit, the shortest rotation), then rolls it by
    ``roll`` about its view axis.

    ``dynamic=True`` adds DCS's drift: a velocity ``u·U(0, 0.4·s)`` (``u`` a random unit vector)
    and roll velocity ``U(±π/50·s)`` at reset, then per walk step ``vel += N(0, (0.1·s·k)²)``
    clipped to norm ``0.4·s·k`` (``k = r0 / 4``), ``roll_vel += N(0, (π/300·s)²)`` clipped to
    ``±π/50·s``; the moved position is clipped to the ranges above in spherical coordinates and
    the velocity set to the move actually made (the same for roll). The walk state lives in
    ``params`` and restarts each episode; every draw comes from ``seed``.

    When it walks: see :class:`DistractionWalk`. ``update_every=2`` walks on the even simulator
    steps as DMC-GB's copy does (``camera.py:283-292``), ``update_every=1`` on every one as the
    original does; ``None`` (the default) ``walk_steps`` times per env step. The walk steps before
    the env step, so the step's frame shows it, and DCS's one walk at reset is kept.

    Departures from the source, on purpose: DCS overwrites the data's camera after each physics
    step, vigen writes the pose into the model fields the camera's mode reads (``cam_pos`` /
    ``cam_quat``, ``cam_pos0`` / ``cam_mat0``, ``cam_poscom0`` / ``cam_mat0``), so every renderer
    sees it (with an odd action repeat, DMC-GB's copy renders the undisturbed camera after every
    env step that ends on an odd control step, since the physics step rewrites the data's camera
    and its wrapper writes it back only on even ones; vigen always shows the walked camera);
    ``d`` is measured at the model's reference pose (``qpos0``), not at the episode's first state;
    scale 0 leaves the camera exactly as it was. Target-body camera modes are refused.

    Source: google-research/google-research ``distracting_control/camera.py`` and ``suite_utils.py``
    (0c1bbe5f); DMC-GB's copy ``src/env/distracting_control/camera.py`` (ff9c0aa8).
    Paper: https://arxiv.org/abs/2101.02722.

    Args:
        scale: the suite's scale ``s`` in [0, 1] (DCS: 0.1 / 0.2 / 0.3; DMC-GB: ``DCS_SCALES``).
        dynamic: drift the camera every step.
        camera: camera id or name (DCS: the render camera, 0; quadruped 2).
        limit_to_upper_quadrant: keep the camera above the ground and on the -y side (DCS: every domain but reacher).
        walk_steps, update_every, seed: see :class:`DistractionWalk`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import DistractingCamera
        >>> env = make_env("dmc/walker-walk", generalization=[DistractingCamera(0.2, dynamic=True, seed=0)], image_size=32)
        >>> env.rollout(3)["pixels"].shape
        torch.Size([3, 9, 32, 32])
    """

    def __init__(
        self,
        scale: float = 0.1,
        dynamic: bool = False,
        camera: int | str = 0,
        limit_to_upper_quadrant: bool = True,
        walk_steps: int = 1,
        update_every: int | None = None,
        seed: int | None = None,
    ) -> None:
        if not isinstance(camera, (int, str)) or isinstance(camera, bool):
            raise TypeError(f"DistractingCamera: camera is a camera id (int) or name (str), got {camera!r}.")
        super().__init__(scale, dynamic, walk_steps, update_every, seed)
        self.camera, self.limit_to_upper_quadrant = camera, bool(limit_to_upper_quadrant)

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        camera = resolve_camera(model, self.camera)
        mode, position, rotation = camera_frame(model, camera)
        data = mujoco.MjData(model)  # the reference pose qpos0, whatever the live data holds
        mujoco.mj_forward(model, data)
        center = data.subtree_com[1] if model.nbody > 1 else np.zeros(3)
        distance = float(np.linalg.norm(data.cam_xpos[camera] - center))
        target = position + rotation @ np.array([0.0, 0.0, -distance])
        s, half = self.scale, math.pi / 2 * self.scale
        r0, h0, v0 = to_sphere(position)
        low = np.array([max(r0 * (1 - 0.5 * s), 0.0), h0 - half, v0 - half])
        high = np.array([r0 * (1 + 1.5 * s), h0 + half, v0 + half])
        if self.limit_to_upper_quadrant:
            low[1:], high[1:] = np.maximum(low[1:], [-math.pi, 0.0]), np.minimum(high[1:], [0.0, math.pi / 2])
        saved = {name: getattr(model, name)[camera].copy() for name in CAMERA_FIELDS[mode]}
        return {"camera": np.array(camera), "mode": np.array(mode), "target": target, "low": low, "high": high,
                "velocity_scale": np.array(r0 / 4), **saved}

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        if self.scale == 0:
            return self.identity_params(defaults)
        s = self.scale
        low, high = defaults["low"], defaults["high"]
        azimuth = rng.uniform(low[1], high[1])
        polar = rng.uniform(low[2], high[2])
        radius = rng.uniform(low[0], high[0])
        roll = rng.uniform(-math.pi / 2 * s, math.pi / 2 * s)
        max_velocity, max_roll_velocity = (0.4 * s, math.pi / 50 * s) if self.dynamic else (0.0, 0.0)
        direction = rng.standard_normal(3)
        velocity = direction / np.linalg.norm(direction) * rng.uniform(0.0, max_velocity)
        params = {"sphere": np.array([radius, azimuth, polar]), "roll": roll, "velocity": velocity,
                  "roll_velocity": rng.uniform(-max_roll_velocity, max_roll_velocity)}
        self.walk(rng, defaults, params)  # DCS applies one walk step at reset
        return params

    def walk(self, rng: np.random.Generator, defaults: Defaults, params: SceneParams) -> None:
        """One step of DCS's random walk of the camera (position velocity and roll velocity), in place."""
        if params["sphere"] is None:  # scale 0: the camera stays as it was
            return
        s = self.scale if self.dynamic else 0.0
        k = float(defaults["velocity_scale"])
        velocity = params["velocity"] + rng.standard_normal(3) * 0.1 * s * k
        roll_velocity = params["roll_velocity"] + rng.standard_normal() * math.pi / 300 * s
        norm = float(np.linalg.norm(velocity))
        if norm > 0.4 * s * k:
            velocity *= 0.4 * s * k / norm
        roll_velocity = float(np.clip(roll_velocity, -math.pi / 50 * s, math.pi / 50 * s))
        start = from_sphere(params["sphere"])
        sphere = np.clip(to_sphere(start + velocity), defaults["low"], defaults["high"])
        roll = float(np.clip(params["roll"] + roll_velocity, -math.pi / 2 * self.scale, math.pi / 2 * self.scale))
        params.update(sphere=sphere, velocity=from_sphere(sphere) - start, roll=roll, roll_velocity=roll - params["roll"])

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {"sphere": None}

    def pose(self, defaults: Defaults, params: SceneParams) -> tuple[np.ndarray, np.ndarray]:
        """The camera's ``(position, rotation)`` in its mode's frame for ``params``."""
        position = from_sphere(params["sphere"])
        look_at = look_at_level if self.limit_to_upper_quadrant else look_at_shortest
        return position, look_at(defaults["target"], position) @ rotation_z(params["roll"])

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        model, camera = scene.model, int(defaults["camera"])
        if params["sphere"] is None:
            for name in CAMERA_FIELDS[int(defaults["mode"])]:
                getattr(model, name)[camera] = defaults[name]
            return
        write_camera(model, camera, int(defaults["mode"]), *self.pose(defaults, params))

    def extra_repr(self) -> str:
        quadrant = "" if self.limit_to_upper_quadrant else ", limit_to_upper_quadrant=False"
        return f"scale={self.scale}, dynamic={self.dynamic}, camera={self.camera!r}{quadrant}{self.schedule_repr()}"


class DistractingColors(DistractionWalk):
    """The Distracting Control Suite's colour distraction at scale ``s``: every material recoloured, drifting if dynamic.

    With ``c0`` a material's default RGB and the box ``[lo, hi] = [clip(c0 - s, 0, 1), clip(c0 + s, 0, 1)]``,
    each episode draws ``c = lo + U(0, 1)·(hi - lo)`` per channel (alpha kept); ``dynamic=True``
    then walks ``c ← clip(c + N(0, (0.03·s)²), lo, hi)`` per walk step. DCS edits ``mat_rgba`` of
    every material and no texture: dm_control's floor is tinted through its ``grid`` material
    (a material's colour multiplies its texture), the skybox (a texture, no material) keeps its colours.

    When it walks: see :class:`DistractionWalk` (``update_every=2``: DMC-GB's ``color.py:75-89``,
    which adds no change on odd control steps; ``1``: the original, every control step;
    ``None``: ``walk_steps`` per env step). The reset draws no walk step, as in the source.

    Departure from the source: draws come from ``seed`` (the original ``color.py`` ignores its seed).

    Source: google-research/google-research ``distracting_control/color.py`` (0c1bbe5f); DMC-GB's
    ``src/env/distracting_control/color.py`` (ff9c0aa8). Paper: https://arxiv.org/abs/2101.02722.

    Args:
        scale: the suite's scale ``s`` in [0, 1] (the colour box half-width).
        dynamic: walk the colours every step.
        parts: name prefixes of the materials to recolour; ``None`` (DCS) recolours every material.
        walk_steps, update_every, seed: see :class:`DistractionWalk`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import DistractingColors
        >>> plain = make_env("dmc/walker-walk", image_size=32, seed=0).reset()["pixels"]
        >>> env = make_env("dmc/walker-walk", generalization=[DistractingColors(0.3, seed=0)], image_size=32, seed=0)
        >>> bool((env.reset()["pixels"] != plain).any())  # the same start, recoloured
        True
    """

    def __init__(
        self,
        scale: float = 0.1,
        dynamic: bool = False,
        parts: Sequence[str] | None = None,
        walk_steps: int = 1,
        update_every: int | None = None,
        seed: int | None = None,
    ) -> None:
        if isinstance(parts, str) or (parts is not None and not all(isinstance(p, str) for p in parts)):
            raise TypeError(f"DistractingColors: parts is a sequence of material name prefixes or None, got {parts!r}.")
        super().__init__(scale, dynamic, walk_steps, update_every, seed)
        self.parts = tuple(parts) if parts is not None else None

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MATERIAL, i) or "" for i in range(model.nmat)]
        materials = np.array([i for i, name in enumerate(names) if self.parts is None or name.startswith(self.parts)],
                             dtype=np.int64)
        if len(materials) == 0:
            raise ValueError(f"DistractingColors(parts={self.parts}) selects no material; the scene's materials are {names}.")
        rgb = model.mat_rgba[materials, :3].copy()
        return {"materials": materials, "rgb": rgb,
                "low": np.clip(rgb - self.scale, 0.0, 1.0), "high": np.clip(rgb + self.scale, 0.0, 1.0)}

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        low, high = defaults["low"], defaults["high"]
        return {"rgb": low + rng.uniform(size=low.shape) * (high - low)}

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {"rgb": defaults["rgb"]}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        scene.model.mat_rgba[defaults["materials"], :3] = params["rgb"]

    def walk(self, rng: np.random.Generator, defaults: Defaults, params: SceneParams) -> None:
        """One step of DCS's colour walk, ``c ← clip(c + N(0, (0.03·s)²), lo, hi)``, in place."""
        rgb = params["rgb"]
        params["rgb"] = np.clip(rgb + rng.standard_normal(rgb.shape) * 0.03 * self.scale, defaults["low"], defaults["high"])

    def extra_repr(self) -> str:
        parts = "" if self.parts is None else f", parts={self.parts}"
        return f"scale={self.scale}, dynamic={self.dynamic}{parts}{self.schedule_repr()}"
