"""A tiny pixel env whose episodes end at random (terminations) and at a step limit (truncations), stacked by TorchRL's
CatFrames as vigen's pixel chain stacks, and the collector batches it gives: what a replay buffer is fed in train.py."""

from __future__ import annotations

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.collectors import Collector
from torchrl.data import Bounded, Composite, Unbounded
from torchrl.envs import CatFrames, Compose, EnvBase, RewardSum, SerialEnv, StepCounter, TransformedEnv

class Flicker(EnvBase):
    """Random uint8 frames ``[3, size, size]`` (every frame differs), a random reward, a termination with probability ``p_end``."""

    def __init__(self, seed: int = 0, p_end: float = 0.15, size: int = 4) -> None:
        super().__init__(batch_size=[])
        self.frame = (3, size, size)
        self.observation_spec = Composite(pixels=Bounded(0, 255, shape=self.frame, dtype=torch.uint8))
        self.action_spec = Bounded(-1.0, 1.0, shape=(2,))
        self.reward_spec = Unbounded(shape=(1,))
        self.p_end, self.rng = p_end, torch.Generator().manual_seed(seed)

    def _frame(self) -> torch.Tensor:
        return torch.randint(0, 256, self.frame, generator=self.rng, dtype=torch.uint8)

    def _reset(self, tensordict: TensorDictBase | None) -> TensorDictBase:
        false = torch.zeros(1, dtype=torch.bool)
        return TensorDict({"pixels": self._frame(), "done": false, "terminated": false.clone(), "truncated": false.clone()}, [])

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        end = torch.rand((1,), generator=self.rng) < self.p_end
        return TensorDict({"pixels": self._frame(), "reward": torch.rand(1, generator=self.rng), "done": end.clone(),
                           "terminated": end, "truncated": torch.zeros(1, dtype=torch.bool)}, [])

    def _set_seed(self, seed: int | None) -> None:
        self.rng.manual_seed(seed or 0)


def make_env(seed: int = 0, frames: int = 3, max_steps: int = 9, size: int = 4) -> TransformedEnv:
    """Flicker with a step limit (truncation), CatFrames' stack of ``frames`` (vigen's pixel chain: padding "same")."""
    return TransformedEnv(Flicker(seed, size=size), Compose(StepCounter(max_steps=max_steps), CatFrames(N=frames, dim=-3, in_keys=["pixels"]),
                                                 RewardSum()))


def collector_batches(workers: int, steps: int, batches: int, seed: int = 0, size: int = 4) -> list[TensorDictBase]:
    """``batches`` collector batches of ``steps`` steps per worker (``[steps]`` for one worker, else ``[workers, steps]``)."""
    if workers == 1:
        env = make_env(seed, size=size)
    else:
        env = SerialEnv(workers, [lambda s=seed + w: make_env(s, size=size) for w in range(workers)])
    collector = Collector(env, None, frames_per_batch=steps * workers, total_frames=steps * workers * batches)
    collector.set_seed(seed)
    out = [batch.clone() for batch in collector]
    collector.shutdown()
    return out


def cut_segment(batch: TensorDictBase) -> TensorDictBase:
    """Mark each worker's last step truncated and done, as train.py does at a segment's end (a checkpoint)."""
    batch = batch.clone()
    batch["next", "truncated"][..., -1, :] = True
    batch["next", "done"][..., -1, :] = True
    return batch
