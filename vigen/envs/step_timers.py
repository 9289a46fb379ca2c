"""Where an env's step time goes, measured inside the env (in each worker's process): physics, rendering, the step, the policy.

:func:`add_step_timers` appends two transforms to an env:

* :class:`SimulatorTimes` writes ``time_physics`` and ``time_render``: the seconds of this step
  spent in the simulator and in rendering, read from a base env that counts them (vigen's
  dm_control and loco envs, :attr:`vigen.envs.dmc.env.DMCPixelEnv.simulator_seconds`); NaN for
  a base env that does not;
* TorchRL's ``Timer`` writes ``time_step`` (the whole step, every transform included),
  ``time_policy`` (from the end of one step to the start of the next: the policy, and the
  collector's own work) and ``time_reset``.

Each is a float per agent step, so the figures travel with the frames through any collector
(a ``MultiSyncCollector``'s processes, Ray actors) to the training loop, where
:func:`step_times` averages them and :func:`without_step_times` drops them before the frames are
stored.
"""

from __future__ import annotations

import math

import torch
from tensordict import TensorDictBase
from torchrl.data import TensorSpec, Unbounded
from torchrl.envs import EnvBase, Timer, Transform

STEP_TIME_KEYS = ("time_step", "time_policy", "time_reset", "time_physics", "time_render")
"""The keys :func:`add_step_timers` adds to each step (seconds, float32)."""


class SimulatorTimes(Transform):
    """Writes the seconds each step spent in the simulator's physics and in rendering (``time_physics``, ``time_render``).

    The base env must count them in a ``simulator_seconds`` property (``{"physics": s, "render":
    s}``, summed since it was built; :class:`vigen.envs.dmc.env.DMCPixelEnv` does); each step gets
    the increase since the previous one. Resets write 0 (their time is TorchRL ``Timer``'s
    ``time_reset``). A base env that does not count them gets NaN.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.envs.step_timers import SimulatorTimes
        >>> env = make_env("dmc/cartpole-balance", image_size=16, seed=0).append_transform(SimulatorTimes())
        >>> steps = env.rollout(3)
        >>> bool((steps["next", "time_render"] > 0).all()), steps["time_physics"][0].item()
        (True, 0.0)
    """

    KEYS = ("time_physics", "time_render")

    def __init__(self) -> None:
        super().__init__(in_keys=[], out_keys=list(self.KEYS))
        self._last: dict[str, float] | None = None

    def _counters(self) -> dict[str, float] | None:
        parent = self.parent
        counters = getattr(parent.base_env, "simulator_seconds", None) if parent is not None else None
        return dict(counters) if counters is not None else None

    def _write(self, tensordict: TensorDictBase, values: dict[str, float]) -> TensorDictBase:
        for key in self.KEYS:
            tensordict.set(key, torch.full(tensordict.batch_size, values[key], dtype=torch.float32, device=tensordict.device))
        return tensordict

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        self._last = self._counters()
        return self._write(tensordict_reset, dict.fromkeys(self.KEYS, 0.0))

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        now = self._counters()
        if now is None or self._last is None:
            values = dict.fromkeys(self.KEYS, math.nan)
        else:
            values = {"time_physics": now["physics"] - self._last["physics"], "time_render": now["render"] - self._last["render"]}
        self._last = now
        return self._write(next_tensordict, values)

    def transform_observation_spec(self, observation_spec: TensorSpec) -> TensorSpec:
        for key in self.KEYS:
            observation_spec[key] = Unbounded(shape=observation_spec.shape, device=observation_spec.device)
        return observation_spec

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        return tensordict


def add_step_timers(env: EnvBase) -> EnvBase:
    """``env`` with :class:`SimulatorTimes` and TorchRL's ``Timer`` appended: every step carries :data:`STEP_TIME_KEYS`.

    Append them last, so that ``time_step`` covers every transform of the chain.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.envs.step_timers import add_step_timers, step_times
        >>> env = add_step_timers(make_env("dmc/cartpole-balance", image_size=16, seed=0))
        >>> times = step_times(env.rollout(4))
        >>> sorted(times), times["step"] >= times["render"] > 0
        (['physics', 'policy', 'render', 'reset', 'step'], True)
    """
    return env.append_transform(SimulatorTimes()).append_transform(Timer(time_key="time"))


def step_times(batch: TensorDictBase) -> dict[str, float]:
    """Mean seconds per agent step of a collected batch (any batch shape): ``step``, ``physics``, ``render``, ``policy``, ``reset``.

    ``reset`` is the resets' time spread over the batch's steps. A figure no step measured (a
    base env that does not count physics and rendering) is NaN.
    """
    steps = max(batch.numel(), 1)
    out = {key.removeprefix("time_"): batch.get(("next", key)).double().mean().item()
           for key in ("time_step", "time_policy", "time_physics", "time_render")}
    out["reset"] = batch.get("time_reset").double().sum().item() / steps
    return out


def without_step_times(batch: TensorDictBase) -> TensorDictBase:
    """``batch`` without the keys :func:`add_step_timers` adds (at its root and under ``"next"``), ready to be stored."""
    present = [key for key in STEP_TIME_KEYS if key in batch.keys()]
    return batch.exclude(*present, *(("next", key) for key in present))
