"""A training run, typed: its settings (:class:`TrainConfig`, presets, protocols), its flags and its agent.

* :class:`TrainConfig`: every setting of ``examples/train.py``, one documented field each, saved as
  the run's ``config.json``; :data:`PRESETS` (``paper``, ``cpu``) are values of it;
  :func:`new_config` layers a preset, :func:`algo_defaults`, flags and a protocol
  (:func:`with_protocol`); :func:`resumed_config` reads a run's ``config.json`` back;
* :func:`add_flags`, :func:`given_flags`: the command line generated from the config's fields;
* :func:`build_agent`: the loss and acting policy of a config, shared by training and
  evaluation; :func:`load_agent`: the same with a run's trained weights.

Examples:
    >>> from dataclasses import replace
    >>> from torchrl.data import Bounded
    >>> from vigen.run import PRESETS, build_agent
    >>> config = replace(PRESETS["cpu"], algo="svea", hidden_dim=32, observation_shape=(9, 84, 84), action_dim=2)
    >>> agent = build_agent(config, Bounded(-1.0, 1.0, shape=(2,)))
    >>> type(agent.loss).__name__
    'SVEALoss'
"""

from vigen.run.agent import Agent, TrainedAgent, build_agent, env_action_spec, explores_with_noise, load_agent
from vigen.run.cli import add_flags, flag_name, flag_value, given_flags, setting
from vigen.run.config import (
    DEFAULT_FRAMES,
    PRESETS,
    PROTOCOL_KEYS,
    WEIGHTS_OPTION,
    TrainConfig,
    algo_defaults,
    new_config,
    resumed_config,
    with_protocol,
)

__all__ = [
    "DEFAULT_FRAMES",
    "PRESETS",
    "PROTOCOL_KEYS",
    "WEIGHTS_OPTION",
    "Agent",
    "TrainConfig",
    "TrainedAgent",
    "add_flags",
    "algo_defaults",
    "build_agent",
    "env_action_spec",
    "explores_with_noise",
    "flag_name",
    "flag_value",
    "given_flags",
    "load_agent",
    "new_config",
    "resumed_config",
    "setting",
    "with_protocol",
]
