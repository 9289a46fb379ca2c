"""Env builders: simulator tasks as TorchRL pixel envs, named ``"<suite>/<env>"``.

Examples:
    >>> from vigen.envs import make_env
    >>> env = make_env("dmc/walker-walk", seed=0)
    >>> env.rollout(100)["pixels"].shape
    torch.Size([100, 9, 84, 84])
"""

from vigen.envs.parallel import ParallelEnv, WorkerError
from vigen.envs.registry import SUITES, available_envs, make_env

__all__ = ["SUITES", "ParallelEnv", "WorkerError", "available_envs", "make_env"]
