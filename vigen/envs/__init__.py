"""Env builders: simulator tasks as TorchRL pixel envs, named ``"<suite>/<task>"``, one :class:`Suite` record per simulator.

Examples:
    >>> from vigen.envs import make_env
    >>> env = make_env("dmc/walker-walk", seed=0)
    >>> env.rollout(100)["pixels"].shape
    torch.Size([100, 9, 84, 84])
"""

from vigen.envs.level_types import level_label
from vigen.envs.parallel import ParallelEnv, WorkerError
from vigen.envs.registry import SUITES, available_envs, check_level_options_used, factors, get_suite, level_options_for, make_env
from vigen.envs.suite import Suite
from vigen.envs.step_timers import SimulatorTimes, add_step_timers, step_times, without_step_times

__all__ = ["SUITES", "ParallelEnv", "SimulatorTimes", "Suite", "WorkerError", "add_step_timers", "available_envs",
           "check_level_options_used", "factors", "get_suite", "level_label", "level_options_for", "make_env", "step_times",
           "without_step_times"]
