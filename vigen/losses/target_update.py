"""Soft target updates with their own rate per part of the networks (DMC-GB: 0.01 for the Q heads, 0.05 for the encoder)."""

from __future__ import annotations

from collections.abc import Mapping

import torch
from torchrl.objectives import LossModule, SoftUpdate


class SplitSoftUpdate(SoftUpdate):
    """TorchRL's ``SoftUpdate`` with another rate for named parts: ``θ' ← (1 − τ_part)·θ' + τ_part·θ``.

    ``taus`` maps a part, written ``"<network>"`` or ``"<network>.<submodule>"`` (``"encoder"``,
    ``"critic.trunk"``), to its rate; every other target parameter moves at ``tau``. DMC-GB's SAC
    (and MaDi, SimGRL, SCPL) moves its target Q heads at ``critic_tau`` 0.01 and its target critic's
    encoder (the convolutions and the projection, which vigen's critic calls its ``trunk``) at
    ``encoder_tau`` 0.05: ``SplitSoftUpdate(loss, tau=0.01, taus={"encoder": 0.05, "critic.trunk": 0.05})``.
    Like ``SoftUpdate`` it is a plain in-place lerp per part, which ``torch.compile`` traces.

    Paper: SAC-AE / DMC-GB's ``soft_update_critic_target``
    (https://github.com/nicklashansen/dmcontrol-generalization-benchmark, ``src/algorithms/sac.py``).

    Args:
        loss_module: a loss with target parameters (``target_critic_params``, ``target_encoder_params``).
        tau: the rate of every target parameter not in a part of ``taus``.
        taus: part → rate, each in (0, 1].

    Raises:
        ValueError: a rate outside (0, 1], or a part that names no target parameters (the message lists them).

    Examples:
        >>> from vigen.losses import make_loss
        >>> loss = make_loss("madi", (9, 64, 64), 2, hidden_dim=8)
        >>> update = SplitSoftUpdate(loss, tau=0.01, taus={"encoder": 0.05, "critic.trunk": 0.05})
        >>> update.rates()
        {'encoder': 0.05, 'critic.trunk': 0.05, 'critic.q1': 0.01, 'critic.q2': 0.01}
        >>> update.step()
    """

    def __init__(self, loss_module: LossModule, *, tau: float, taus: Mapping[str, float]) -> None:
        for name, rate in {"tau": tau, **taus}.items():
            if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate <= 1:
                raise ValueError(f"SplitSoftUpdate: the rate of {name!r} must be in (0, 1], got {rate!r}.")
        super().__init__(loss_module, tau=tau)
        self.taus = {name: float(rate) for name, rate in taus.items()}
        leaves = [key for key in self._sources.keys(True, True)]
        parts: list[tuple[str, list[tuple[str, ...]], float]] = []
        taken: set[tuple[str, ...]] = set()
        for name, rate in self.taus.items():
            network, _, sub = name.partition(".")
            prefix = (f"{network}_params", *([*sub.split(".")] if sub else []))
            keys = [key for key in leaves if key[:len(prefix)] == prefix and key not in taken]
            if not keys:
                known = sorted({".".join([key[0].removesuffix("_params"), *key[1:2]]) for key in leaves} |
                               {key[0].removesuffix("_params") for key in leaves})
                raise ValueError(f"SplitSoftUpdate: {type(loss_module).__name__} has no target parameters under {name!r}; "
                                 f"the parts are {', '.join(known)}.")
            taken.update(keys)
            parts.append((name, keys, rate))
        rest: dict[str, list[tuple[str, ...]]] = {}
        for key in leaves:
            if key not in taken:
                rest.setdefault(".".join([key[0].removesuffix("_params"), *key[1:2]]), []).append(key)
        parts += [(name, keys, float(tau)) for name, keys in rest.items()]
        self._parts = [(name, [self._targets.get((f"target_{key[0]}", *key[1:])) for key in keys],
                        [self._sources.get(key) for key in keys], rate) for name, keys, rate in parts]

    def rates(self) -> dict[str, float]:
        """Each part and the rate it moves at (the named parts, then the rest by network and submodule)."""
        return {name: rate for name, _, _, rate in self._parts}

    def step(self) -> None:
        """``θ' ← θ' + τ_part·(θ − θ')`` in place, one fused lerp per part."""
        for _, targets, sources, rate in self._parts:
            torch._foreach_lerp_([target.data for target in targets], [source.data for source in sources], rate)
