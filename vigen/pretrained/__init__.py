"""Trained agents that ship with vigen: their acting policies (encoder and actor only) and where they came from.

Each agent is two files in ``vigen/pretrained/agents/``: ``<name>.pt``, the weights (tensors and
plain data, loaded with ``weights_only=True``, stored in float16 to keep the wheel small and
restored to float32), and ``<name>.json``, its provenance: the vigen commit and command that
trained it, its algorithm, env, seed and frames, the SHA-256 of the weights file, and its
zero-shot evaluation table, measured on these very weights. :func:`export_policy` writes both
from a run of ``examples/train.py``; :func:`load_agent` builds an agent back through
:func:`vigen.run.build_agent` from its recorded config, and :func:`load_policy` gives its policy.

Examples:
    >>> import tempfile, torch
    >>> from torchrl.data import Bounded
    >>> from vigen.pretrained import available, export_policy, load_policy
    >>> from vigen.run import TrainConfig, build_agent
    >>> folder, spec = tempfile.mkdtemp(), Bounded(-1.0, 1.0, shape=(1,))
    >>> config = TrainConfig(algo="drqv2", hidden_dim=16, observation_shape=(9, 32, 32), action_dim=1)
    >>> agent = build_agent(config, spec)
    >>> _ = export_policy(config, agent.loss, spec, folder, "tiny", {"env": "dmc/cartpole-balance"})
    >>> available(folder)
    ['tiny']
    >>> policy = load_policy("tiny", root=folder)
    >>> policy(pixels=torch.zeros(9, 32, 32, dtype=torch.uint8)).shape
    torch.Size([1])
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import torch
from tensordict.nn import TensorDictModuleBase, TensorDictSequential
from torchrl.data import Bounded, TensorSpec

from vigen.run.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from vigen.io import atomic_write
from vigen.losses import ActorCriticLoss
from vigen.run.agent import TrainedAgent, build_agent
from vigen.run.config import TrainConfig

AGENTS = Path(__file__).parent / "agents"
"""The folder of the shipped agents."""
FORMAT = 1
"""The version of the weights file's layout."""
ACTING_PARTS = ("input_mask", "encoder", "actor")
"""The loss's modules a policy acts with (``input_mask`` only where the algorithm has one, e.g. MaDi)."""
SHAPE_KEYS = ("algo", "observation_shape", "action_dim", "feature_dim", "hidden_dim")
"""The config fields the weights file records: what the networks are built with."""
NO_EXPLORATION = {"std_init": 0.0, "std_final": 0.0}
"""The config settings a shipped agent's policy is built with: it acts without exploration noise."""


def available(root: str | Path | None = None) -> list[str]:
    """The names of the agents in ``root`` (default: the ones vigen ships), sorted.

    Examples:
        >>> from vigen.pretrained import available
        >>> isinstance(available(), list)
        True
    """
    folder = Path(root) if root is not None else AGENTS
    return sorted(path.stem for path in folder.glob("*.pt") if path.with_suffix(".json").is_file())


def info(name: str, *, root: str | Path | None = None) -> dict[str, Any]:
    """An agent's provenance: commit, command, algorithm, env, seed, frames, weights checksum and evaluation table.

    ``name`` is a shipped agent's name (:func:`available`), or the path of a ``.pt`` file written by
    :func:`export_policy` (its ``.json`` beside it); so in :func:`load_config` and :func:`load_policy`.
    """
    return json.loads(_files(name, root)[1].read_text())


def load_config(name: str, *, root: str | Path | None = None) -> TrainConfig:
    """The training config of an agent (its env, action repeat, frame stack, image size, algorithm, seed)."""
    return TrainConfig.from_json(info(name, root=root)["config"])


def load_agent(name: str, *, device: torch.device | str = "cpu", root: str | Path | None = None) -> TrainedAgent:
    """A shipped agent as a run's agent: built from its training config by :func:`vigen.run.build_agent`, with its weights.

    The agent is built as ``examples/train.py`` builds it, with the exploration std set to 0: its
    policy acts without noise (see :func:`load_policy`). Only the acting parts are loaded (encoder,
    actor, input mask); the critic keeps its initial weights. The weights file is checked against
    the checksum in the provenance and loaded with ``weights_only=True``; float16 values are
    restored to float32 exactly, each part strictly (every key of the module, no other).

    Returns:
        The config the agent was trained with (its recorded ``config``, with the file's network
        sizes), the agent, its training frames (0 where the provenance records none) and the
        weights file.

    Raises:
        KeyError: no agent of that name (the message lists the available ones).
        CheckpointError: the weights file is corrupt, altered, or not in this format.

    Examples:
        >>> from vigen.pretrained import load_agent
        >>> shipped = load_agent("svea-cartpole-balance")
        >>> shipped.config.algo, shipped.frames, type(shipped.agent.loss).__name__
        ('svea', 30000, 'SVEALoss')
    """
    weights, provenance = _files(name, root)
    record = json.loads(provenance.read_text())
    digest = hashlib.sha256(weights.read_bytes()).hexdigest()
    if record.get("sha256") != digest:
        raise CheckpointError(f"{weights} does not match the checksum in {provenance.name} (sha256 {digest[:12]}…, "
                              f"recorded {str(record.get('sha256'))[:12]}…): the file was altered or truncated.")
    state = load_checkpoint(weights)
    if state.get("format") != FORMAT or any(key not in state for key in (*SHAPE_KEYS, "parts", "action_low", "action_high")):
        raise CheckpointError(f"{weights} is not a vigen policy file of format {FORMAT}; write it with export_policy.")
    shapes = {**{key: state[key] for key in SHAPE_KEYS}, "observation_shape": tuple(state["observation_shape"])}
    config = replace(TrainConfig.from_json(record.get("config", {})), **shapes)
    low, high = state["action_low"], state["action_high"]
    agent = build_agent(replace(config, **NO_EXPLORATION), Bounded(low, high, shape=low.shape), device=device,
                        pretrained=False)
    for part, tensors in state["parts"].items():
        getattr(agent.loss, part).load_state_dict(tensors)  # copied into float32 parameters: float16 values exactly
    return TrainedAgent(config, agent, record.get("frames", 0), weights, [])


def load_policy(name: str, *, device: torch.device | str = "cpu", root: str | Path | None = None) -> TensorDictModuleBase:
    """The acting policy of a shipped agent: a TorchRL module from ``"pixels"`` (uint8, ``(3·frames, H, W)``) to ``"action"``.

    The policy acts deterministically: DrQ-v2-style agents output the actor's action with no
    exploration noise (clamped to the env's bounds), SAC-style ones the squashed mean unless run
    under ``ExplorationType.RANDOM``. It is the policy of :func:`load_agent`'s agent.

    Raises:
        KeyError: no agent of that name (the message lists the available ones).
        CheckpointError: the weights file is corrupt, altered, or not in this format.
    """
    policy = load_agent(name, device=device, root=root).agent.policy
    return TensorDictSequential(policy, selected_out_keys=["action"])


def export_policy(
    config: TrainConfig,
    loss: ActorCriticLoss,
    action_spec: TensorSpec,
    root: str | Path,
    name: str,
    provenance: Mapping[str, Any],
    *,
    dtype: torch.dtype = torch.float16,
    overwrite: bool = False,
) -> tuple[Path, Path]:
    """Write the acting part of ``loss`` (encoder, actor, input mask) as ``root/<name>.pt`` and its provenance as ``.json``.

    Args:
        config: the run's config (its algorithm and network sizes), e.g. ``vigen.run.load_agent(run).config``.
        loss: the trained loss built from it, e.g. ``vigen.run.load_agent(run).agent.loss``.
        action_spec: the env's action spec (its bounds are stored with the weights).
        root: the folder to write into.
        name: the agent's name, e.g. ``"drqv2-cartpole-balance"``.
        provenance: what made it (commit, command, env, seed, frames, evaluation table); the
            network sizes, the run's whole config (``config``) and the weights' SHA-256 are added.
        dtype: the floating dtype stored (float16 halves the file; loading restores float32).
        overwrite: replace an agent of that name; otherwise an existing one is an error.

    Returns:
        The paths of the weights and of the provenance.
    """
    if not isinstance(loss, ActorCriticLoss):
        raise TypeError(f"export_policy takes a vigen loss (an ActorCriticLoss), got {type(loss).__name__}.")
    if not name or "/" in name or name.startswith("."):
        raise ValueError(f"export_policy: {name!r} is not a usable agent name (a file name without '/').")
    weights, record = Path(root) / f"{name}.pt", Path(root) / f"{name}.json"
    if not overwrite and (weights.exists() or record.exists()):
        raise FileExistsError(f"{weights} or {record.name} exists; pass overwrite=True to replace agent {name!r}.")
    shapes = {key: getattr(config, key) for key in SHAPE_KEYS}
    if shapes["observation_shape"] is None or shapes["action_dim"] is None:
        raise ValueError("export_policy: the config has no observation_shape / action_dim; pass the run's config.")
    shapes["observation_shape"] = list(shapes["observation_shape"])
    parts = {part: {key: value.detach().to("cpu", dtype if value.is_floating_point() else value.dtype).clone()
                    for key, value in getattr(loss, part).state_dict().items()}
             for part in ACTING_PARTS if getattr(loss, part, None) is not None}
    space = action_spec.space
    state = {"format": FORMAT, **shapes, "parts": parts,
             "action_low": torch.as_tensor(space.low, dtype=torch.float32).cpu().clone(),
             "action_high": torch.as_tensor(space.high, dtype=torch.float32).cpu().clone()}
    Path(root).mkdir(parents=True, exist_ok=True)
    save_checkpoint(weights, state)
    digest = hashlib.sha256(weights.read_bytes()).hexdigest()
    atomic_write(record, json.dumps({**provenance, **shapes, "config": config.to_json(), "sha256": digest,
                                     "dtype": str(dtype).removeprefix("torch.")},
                                    indent=2, default=str) + "\n")
    return weights, record


def _files(name: str, root: str | Path | None) -> tuple[Path, Path]:
    """The weights and provenance of agent ``name`` in ``root`` (default: the shipped ones), or of the ``.pt`` file ``name``."""
    folder = Path(root) if root is not None else AGENTS
    if name.endswith(".pt"):  # a file: relative to root when one is given, else to the working directory
        weights = Path(root) / name if root is not None else Path(name)
    else:
        weights = folder / f"{name}.pt"
    record = weights.with_suffix(".json")
    if not (weights.is_file() and record.is_file()):
        where = f"{weights} with its .json beside it" if name.endswith(".pt") else f"{name!r} in {folder}"
        raise KeyError(f"no pretrained agent {where}; available: {', '.join(available(folder)) or 'none'}.")
    return weights, record
