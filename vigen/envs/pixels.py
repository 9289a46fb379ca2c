"""What every vigen pixel env shares: its specs, and the transform chain from raw frames to stacked pixels."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import torch
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import CatFrames, Compose, EnvBase, ToTensorImage, Transform, TransformedEnv

from vigen.transforms.scene import ScenePerturbation


def check_transforms(transforms: Sequence[Transform] | None) -> list[Transform]:
    """``generalization`` given as transforms: a list of TorchRL ``Transform``s (``None`` is none)."""
    built = list(transforms or [])
    for transform in built:
        if not isinstance(transform, Transform):
            raise TypeError(f"generalization takes a level name or a list of TorchRL transforms, got {transform!r}.")
    return built


def perturbations(
    generalization: str | Sequence[Transform] | None, level_transforms: Callable[[str], list[Transform]]
) -> list[Transform]:
    """The transforms of ``make_env(..., generalization=...)``: a level name's (built by ``level_transforms``) or the given ones."""
    if isinstance(generalization, str):
        return level_transforms(generalization)
    return check_transforms(generalization)


def stacked_pixel_env(base: EnvBase, transforms: Sequence[Transform], frame_stack: int, *extra: Transform) -> TransformedEnv:
    """``base`` (uint8 HWC ``"pixels"``) with its perturbations, channel-first frames and a stack of ``frame_stack``.

    Scene perturbations come first (they edit the model and may composite raw frames), then
    ``ToTensorImage`` (HWC → CHW, uint8 kept), then pixel perturbations on each frame, then
    ``CatFrames`` along channels, then ``extra`` transforms.
    """
    if frame_stack < 1:
        raise ValueError(f"frame_stack must be at least 1, got {frame_stack}.")
    chain = [t for t in transforms if isinstance(t, ScenePerturbation)]
    chain.append(ToTensorImage(in_keys=["pixels"], from_int=False, dtype=torch.uint8))
    chain += [t for t in transforms if not isinstance(t, ScenePerturbation)]
    if frame_stack > 1:
        chain.append(CatFrames(N=frame_stack, dim=-3, in_keys=["pixels"]))
    return TransformedEnv(base, Compose(*chain, *extra))


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
