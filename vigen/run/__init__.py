"""A training run, typed: its settings (:class:`TrainConfig`, presets, protocols), its flags and its agent.

* :class:`TrainConfig`: every setting of ``examples/train.py``, one documented field each, saved as
  the run's ``config.json``; :data:`PRESETS` (``paper``, ``cpu``) are values of it;
  :data:`RECIPES`: each method's original training settings by name (``--recipe svea-dmcgb``);
  :func:`new_config` layers a preset, flags, a recipe (:func:`with_recipe`) and a protocol (:func:`with_protocol`);
  :func:`resumed_config` reads a run's ``config.json`` back; settings left unset take their
  algorithm's value when the run is built;
* :func:`parse_flags`: the command line of a script's settings dataclasses, parsed by tyro, with the flags typed;
* :func:`check_runnable`: the checks that need the simulators, losses or Ray; :func:`build_agent`:
  the loss and acting policy of a config, shared by training and evaluation; :func:`load_agent`:
  the same with a run's trained weights; :func:`make_update`: its optimizer, target update and schedule;
* the training loop's parts, which ``examples/train.py`` calls by name: the run folder
  (:func:`new_run_folder`, :func:`resumed_run_config`, :func:`enclosing_run_folder`) and its
  checkpoints (:class:`TrainingState`; the files themselves: :mod:`vigen.run.checkpoint`);
  :class:`RunSchedule` (agent steps per collector batch and segment); :class:`SegmentCollectors`
  (each segment's collector, or ``--overlap``'s kept workers) and :class:`CollectorBatches` (a
  collector's batches, serial or collected in the background while the loop updates);
  :class:`RunReplay` (the memory-mapped replay buffer, its n-step store and its optional copy in the
  device's memory), :class:`FrameReplay` (a replay buffer on the device that keeps one frame per
  observation and rebuilds stacks and n-step transitions), :class:`SampledUpdate` (an update on a
  batch sampled on the device, both captured as one CUDA graph), :class:`StageTimes`,
  :class:`StageClock` and :class:`GpuBusy` (where the loop's time goes); :func:`worker_timeouts`
  (what TorchRL waits for its worker processes, set where they start).

``vigen.run.config`` imports no simulator, loss, torch or Ray module (this package loads its
names lazily).

Examples:
    >>> from dataclasses import replace
    >>> from torchrl.data import Bounded
    >>> from vigen.run import PRESETS, build_agent
    >>> config = replace(PRESETS["cpu"], algo="svea", hidden_dim=32, observation_shape=(9, 84, 84), action_dim=2)
    >>> agent = build_agent(config, Bounded(-1.0, 1.0, shape=(2,)))
    >>> type(agent.loss).__name__
    'SVEALoss'
"""

from __future__ import annotations

import importlib
from typing import Any

_HOMES = {
    "Agent": "agent", "TrainedAgent": "agent", "build_agent": "agent", "check_runnable": "agent",
    "env_action_spec": "agent", "exploration_std_schedule": "agent", "load_agent": "agent", "make_update": "agent",
    "recipe_loss_options": "agent", "recipe_weights": "agent", "RECIPES": "recipes", "Recipe": "recipes",
    "list_recipes": "recipes", "with_recipe": "config",
    "CollectorBatches": "collection", "SegmentCollectors": "collection", "make_collector": "collection",
    "worker_env": "collection", "worker_timeouts": "collection", "FrameReplay": "frame_replay", "frame_bytes": "frame_replay",
    "SampledUpdate": "sampled_update", "GpuBusy": "timing", "StageClock": "timing", "StageTimes": "timing",
    "busy_seconds": "timing", "RunReplay": "replay", "check_device_fits": "replay", "to_device": "replay",
    "transition_bytes": "replay", "RunSchedule": "schedule", "Resumed": "training_state", "TrainingState": "training_state",
    "new_run_folder": "folder", "resumed_run_config": "folder", "enclosing_run_folder": "folder",
    "BareValue": "cli", "Parsed": "cli", "RayAddress": "cli", "flag_name": "cli", "flag_value": "cli", "parse_flags": "cli", "unset_means": "cli",
    "DEFAULT_FRAMES": "config", "PRESETS": "config", "PROTOCOL_KEYS": "config", "TrainConfig": "config",
    "new_config": "config", "resumed_config": "config", "with_protocol": "config",
}
"""Each public name → its module; a name is imported on first use, so ``vigen.run.config`` loads without torch."""

__all__ = sorted(_HOMES)


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module 'vigen.run' has no attribute {name!r}")
    return getattr(importlib.import_module(f"vigen.run.{_HOMES[name]}"), name)


def __dir__() -> list[str]:
    return __all__
