"""What every vigen pixel env shares: argument checks, seeds, specs, and the transform chain from raw frames to stacked pixels."""

from __future__ import annotations

import numbers
from collections.abc import Iterator, Sequence
from typing import Any

import torch
from tensordict import TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import CatFrames, Compose, EnvBase, ToTensorImage, Transform, TransformedEnv

from vigen.envs.failure_report import failures_recorded
from vigen.seeding import ENV_SEED_LIMIT as SEED_LIMIT
from vigen.seeding import derive_seed
from vigen.transforms.augmentations.base import ImageAugmentation
from vigen.transforms.scene import SceneTransform


POSITIVE_ARGUMENTS = {
    "image_size": "pixels per side of the rendered frame, e.g. image_size=84",
    "frame_stack": "frames stacked along channels, e.g. frame_stack=3 (1: no stacking)",
    "action_repeat": "control steps per agent step, e.g. action_repeat=2 (1: no repeat)",
    "episode_length": "control steps per episode, e.g. episode_length=1000",
    "control_freq": "control steps per simulated second, e.g. control_freq=20",
    "max_mesh_faces": "faces per mesh after simplification, e.g. max_mesh_faces=3000 (None: the source meshes)",
}
"""Env arguments that must be ints > 0, with what they mean."""


def check_env_arguments(**arguments: Any) -> None:
    """Raise a clear error for an env argument of the wrong type or value, before anything is built.

    ``image_size``, ``frame_stack``, ``action_repeat``, ``episode_length`` and ``control_freq``
    must be ints > 0 (``episode_length=None`` keeps a suite's default); ``seed`` an int in
    ``[0, 2**32)`` or ``None``; ``camera_id`` an int >= 0 or ``None``; ``camera`` a camera name.
    Bools are refused where ints are wanted. Arguments left out are not checked.

    Examples:
        >>> check_env_arguments(image_size=84, frame_stack=3, seed=None)
        >>> check_env_arguments(image_size=84.0)
        Traceback (most recent call last):
        ...
        TypeError: image_size must be an int > 0, got 84.0 (float). image_size is pixels per side of the rendered frame, e.g. image_size=84.
    """
    for name, value in arguments.items():
        if name in POSITIVE_ARGUMENTS:
            if name == "episode_length" and value is None:
                continue
            _check_int(name, value, 1, f"{name} is {POSITIVE_ARGUMENTS[name]}.")
        elif name == "seed":
            if value is not None:
                _check_int(name, value, 0, "Pass seed=None to draw one.", high=SEED_LIMIT - 1)
        elif name == "camera_id":
            if value is not None:
                _check_int(name, value, 0, "camera_id indexes the model's cameras; None picks the suite's default.")
        elif name == "camera":
            if not isinstance(value, str):
                raise TypeError(f"camera must be a camera name (str), got {value!r} ({type(value).__name__}).")
        else:
            raise ValueError(f"check_env_arguments has no rule for {name!r}; known: {', '.join([*POSITIVE_ARGUMENTS, 'seed', 'camera_id', 'camera'])}.")


def _check_int(name: str, value: Any, low: int, hint: str, high: int | None = None) -> None:
    wanted = f"an int > {low - 1}" if high is None else f"an int in [{low}, {high}]"
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be {wanted}, got {value!r} ({type(value).__name__}). {hint}")
    if value < low or (high is not None and value > high):
        raise ValueError(f"{name} must be {wanted}, got {value}. {hint}")


def flatten_transforms(transforms: Sequence[Transform]) -> list[Transform]:
    """``transforms`` with every ``Compose`` replaced by its transforms (recursively), in order.

    Examples:
        >>> from torchrl.envs import Compose, StepCounter
        >>> from vigen.transforms import RandomShift
        >>> [type(t).__name__ for t in flatten_transforms([Compose(RandomShift(), Compose(StepCounter()))])]
        ['RandomShift', 'StepCounter']
    """
    flat: list[Transform] = []
    for transform in transforms:
        if isinstance(transform, Compose):
            inner = flatten_transforms(list(transform.transforms))
            for child in inner:
                child.reset_parent()  # the Compose is dissolved: each child joins the env's chain on its own
            flat += inner
        else:
            flat.append(transform)
    return flat


def check_transforms(transforms: Sequence[Transform] | None) -> list[Transform]:
    """``generalization`` given as transforms: a list of TorchRL ``Transform``s (``None`` is none), ``Compose`` flattened."""
    if isinstance(transforms, Transform):
        transforms = [transforms]
    built = list(transforms or [])
    for transform in built:
        if not isinstance(transform, Transform):
            raise TypeError(f"generalization takes a level name or a list of TorchRL transforms, got {transform!r}.")
    return flatten_transforms(built)


def seeded_transforms(transform: Transform) -> Iterator[Transform]:
    """The transforms of a chain that draw from their own seed (scene perturbations, image augmentations), in chain order."""
    if isinstance(transform, Compose):
        for child in transform.transforms:
            yield from seeded_transforms(child)
    elif isinstance(transform, (SceneTransform, ImageAugmentation)):
        yield transform


class PixelEnv(TransformedEnv):
    """A vigen pixel env: a ``TransformedEnv`` whose ``set_seed`` also reseeds its perturbations (and picks the scene).

    TorchRL's ``TransformedEnv.set_seed`` seeds the base env only. Here ``set_seed(s)`` seeds the
    base env with ``s`` and then every scene transform and image augmentation of the chain,
    the ``i``-th (in chain order) with :func:`derive_seed` ``(s, i)``, which is what
    ``make_env(..., seed=s)`` does at build time, so ``make_env(name, generalization=level).set_seed(s)``
    and ``make_env(name, generalization=level, seed=s)`` give the same episodes. ``ParallelEnv.set_seed``
    reaches it in each worker. ``set_seed(None)`` changes nothing.

    Levels with several scenes (robosuite: RL-ViGen's 10 per level) show scene ``scene_id``.
    Built without an explicit ``scene_id``, the scene follows the seed: ``set_seed(s)`` moves it
    to ``s % scenes``, the scene ``make_env(..., seed=s)`` builds. An explicit ``scene_id`` stays
    through ``set_seed``; :meth:`set_scene` changes it either way.

    With a ``failure_report`` path (:class:`vigen.envs.ParallelEnv` sets one in each worker),
    an exception raised by a step, a reset or ``set_seed`` first writes its traceback there,
    then propagates unchanged, so the parent process can show it.

    Args:
        base_env: the raw-frame env.
        transform: its transform chain.
        level: the built level (:class:`~vigen.envs.suite.BuiltLevel`), or ``None`` for user transforms.
        scenes: how many scenes the suite's levels have.
        scene_id: the scene shown now.
        scene_follows_seed: whether ``set_seed(s)`` moves the level to scene ``s % scenes``.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", generalization="color_hard", image_size=32)
        >>> _ = env.set_seed(3)
        >>> [t.seed for t in env.transform if hasattr(t, "seed")]
        [3000009]
    """

    failure_report: str | None = None
    """The file a failure of a step, reset or ``set_seed`` is written to (``None``: not written)."""

    def __init__(self, base_env: EnvBase, transform: Transform | None = None, *, level: Any = None, scenes: int = 1,
                 scene_id: int = 0, scene_follows_seed: bool = True, **kwargs: Any) -> None:
        check_scene_id(scene_id, scenes)
        super().__init__(base_env, transform, **kwargs)
        self.level, self.scenes, self.scene_id, self.scene_follows_seed = level, scenes, int(scene_id), scene_follows_seed

    def set_seed(self, seed: int | None = None, static_seed: bool = False) -> int | None:
        """Seed the base env and every perturbation of the chain from ``seed`` (and move to scene ``seed % scenes``); returns the next seed."""
        with failures_recorded(self.failure_report):
            check_env_arguments(seed=seed)
            if seed is not None and self.scene_follows_seed and self.scenes > 1:
                self.set_scene(seed % self.scenes)
            next_seed = self.base_env.set_seed(seed, static_seed=static_seed)
            if seed is not None:
                self.seed_transforms(seed)
            return next_seed

    def set_scene(self, scene_id: int) -> None:
        """Show the level's scene ``scene_id`` from the next reset on."""
        check_scene_id(scene_id, self.scenes)
        if self.level is not None:
            self.level.select_scene(int(scene_id))
        self.scene_id = int(scene_id)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        with failures_recorded(self.failure_report):
            return super()._step(tensordict)

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        with failures_recorded(self.failure_report):
            return super()._reset(tensordict, **kwargs)

    def seed_transforms(self, seed: int) -> None:
        """Reseed the chain's scene transforms and image augmentations from ``seed``, the ``i``-th with ``derive_seed(seed, i)``."""
        seed_in_order(list(seeded_transforms(self.transform)), seed)


def check_scene_id(scene_id: Any, scenes: int) -> None:
    """Raise a clear error unless ``scene_id`` is an int in ``0..scenes-1``.

    Examples:
        >>> check_scene_id(3, 10)
        >>> check_scene_id(10, 10)
        Traceback (most recent call last):
        ...
        ValueError: scene_id selects one of the level's 10 scenes: 0..9, got 10.
    """
    if isinstance(scene_id, bool) or not isinstance(scene_id, numbers.Integral):
        raise TypeError(f"scene_id must be an int in 0..{scenes - 1} (or None: seed % {scenes}), got {scene_id!r} ({type(scene_id).__name__}).")
    if not 0 <= scene_id < scenes:
        raise ValueError(f"scene_id selects one of the level's {scenes} scenes: 0..{scenes - 1}, got {scene_id}.")


def seed_in_order(transforms: Sequence[Transform], seed: int | None) -> list[Transform]:
    """Give the ``i``-th transform the seed ``derive_seed(seed, i)`` (``seed=None``: leave them as they are); returns them.

    Examples:
        >>> from vigen.transforms import RandomConv, RandomShift
        >>> [t.seed for t in seed_in_order([RandomShift(), RandomConv()], 1)]
        [1000003, 1000004]
    """
    if seed is not None:
        for index, transform in enumerate(transforms):
            transform.set_seed(derive_seed(seed, index))
    return list(transforms)


def stacked_pixel_env(
    base: EnvBase,
    transforms: Sequence[Transform],
    frame_stack: int,
    *extra: Transform,
    seed: int | None = None,
    **env_options: Any,
) -> PixelEnv:
    """``base`` (uint8 HWC ``"pixels"``) with its perturbations, channel-first frames and a stack of ``frame_stack``.

    Scene perturbations come first (they edit the model and may composite raw frames), then
    ``ToTensorImage`` (HWC → CHW, uint8 kept), then pixel perturbations on each frame, then
    ``CatFrames`` along channels, then ``extra`` transforms. With a ``seed``, the perturbations
    are seeded as :meth:`PixelEnv.set_seed` seeds them (the base env is seeded by its builder).
    ``env_options`` go to :class:`PixelEnv` (the level and its scene).
    """
    check_env_arguments(frame_stack=frame_stack)
    transforms = check_transforms(transforms)
    chain = [t for t in transforms if isinstance(t, SceneTransform)]
    chain.append(ToTensorImage(in_keys=["pixels"], from_int=False, dtype=torch.uint8))
    chain += [t for t in transforms if not isinstance(t, SceneTransform)]
    if frame_stack > 1:
        chain.append(CatFrames(N=frame_stack, dim=-3, in_keys=["pixels"]))
    env = PixelEnv(base, Compose(*chain, *extra), **env_options)
    if seed is not None:
        env.seed_transforms(seed)
    return env


def set_task_specs(env: EnvBase, low: object, high: object, image_size: int) -> None:
    """The specs of a pixel task with a success flag: float32 actions in ``[low, high]``, uint8 HWC pixels, float32 reward."""
    low, high = torch.as_tensor(low, dtype=torch.float32), torch.as_tensor(high, dtype=torch.float32)
    env.action_spec = Bounded(low, high, shape=low.shape, dtype=torch.float32, device=env.device)
    env.observation_spec = Composite(
        pixels=Unbounded((image_size, image_size, 3), dtype=torch.uint8, device=env.device),
        success=Categorical(2, (1,), dtype=torch.bool, device=env.device),
        device=env.device,
    )
    env.reward_spec = Unbounded((1,), dtype=torch.float32, device=env.device)
    flag = Categorical(2, (1,), dtype=torch.bool, device=env.device)
    env.done_spec = Composite(done=flag.clone(), terminated=flag.clone(), truncated=flag.clone(), device=env.device)
