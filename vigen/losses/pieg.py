"""PIE-G: SVEA's update on DrQ-v2's DDPG, on a frozen ImageNet ResNet-18 encoder with adapting BatchNorms."""

from __future__ import annotations

from typing import Any, Literal

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase, dispatch
from tensordict.utils import NestedKey
from torch import Tensor, nn
from torchrl.data import TensorSpec

from vigen.losses.base import BATCH_NORMS, PixelsToAction, RunningStatistics
from vigen.losses.svea import TwoViewLoss, svea_critic

BatchNormMode = Literal["running", "observation"]


class PIEGLoss(TwoViewLoss):
    """PIE-G as RL-ViGen (and PIE-G's own code) trains it: SVEA's critic loss on a frozen ResNet-18 encoder.

    The update is SVEA's (:class:`~vigen.losses.SVEALoss`, its critic :func:`~vigen.losses.svea.svea_critic`) on
    DrQ-v2's DDPG, with ``s = shift(obs)``,
    ``s̃ = overlay(s)`` and ``y = r + γⁿ·(1 − terminated)·min(Q1', Q2')(h', a')``:

        ``loss_critic = w·[MSE(Q1(h), y) + MSE(Q2(h), y)] + w̃·[MSE(Q1(h̃), y) + MSE(Q2(h̃), y)]``

    with w = w̃ = 0.5 (RL-ViGen's, the record ``ALGOS["pieg"]``), ``h = encoder(s)``, ``h̃ = encoder(s̃)``, ``h' = encoder(shift(next obs))``
    (no gradient), and ``loss_actor = −min(Q1, Q2)(h.detach(), μ(h.detach()) + noise)``.

    What PIE-G changes is the encoder, :class:`~vigen.models.PIEGEncoder`: ImageNet ResNet-18
    layers up to ``layer2`` with frozen weights, run on every frame, then a Linear → LayerNorm
    head, the only part of it that learns (from the critic loss). Its BatchNorm layers:

    * **in the update**, training mode: each encoder pass normalises with its own batch's
      statistics and moves the running statistics, although the weights are frozen. The clean
      view, the overlaid view and the next view are encoded in three separate passes (three
      batch statistics), as RL-ViGen does, not concatenated into one as SVEA's are;
    * **while acting** (:meth:`make_policy`), ``acting_batchnorm``: ``"running"`` (default) uses
      the running statistics, as RL-ViGen collects data and evaluates during training (its
      agent in eval mode); ``"observation"`` normalises every observation with the statistics
      of its own frames, as RL-ViGen's standalone evaluators (``eval.py``, ``locoeval.py``,
      ``eval_adroit.py``) and PIE-G's ``reseval.py`` run it, on purpose, in training mode.
      Neither moves the running statistics (RL-ViGen's evaluators do, on a loaded copy whose
      running statistics they never read).

    :meth:`reset_parameters_recursive` re-initialises the actor, the critic and the encoder's
    head but keeps the frozen ResNet weights (the ImageNet ones, when loaded) and puts the
    BatchNorm statistics back to their loaded values.

    Departures from RL-ViGen: the next view is encoded first (vigen's update computes the
    target before the critic loss), so the running statistics see the three batches in another
    order (RL-ViGen: clean, overlaid, next); the outputs, which use batch statistics, are the
    same. One ``backward()`` of the summed ``loss_*`` entries replaces the separate critic and
    actor steps, as in :class:`~vigen.losses.DrQv2Loss`. RL-ViGen's Adroit branch runs PIE-G on
    VRL3's stage-3 update instead (safe Q target, std 0.01, feature_dim 256, hand joint
    positions next to the image features); this loss is the master branch's (DMC, robosuite).

    RL-ViGen's hyper-parameters (``cfgs/pieg_config.yaml``): encoder output 1024, feature_dim 50,
    hidden_dim 1024, Adam lr 1e-4 for everything, batch 256, n-step 3, γ 0.99, τ 0.01, noise std
    ``linear(1.0, 0.1, ·)`` per task with clip 0.3, three stacked 84×84 frames, action repeat 2.
    PIE-G's own code (``gemcollector/PIE-G``) is the same but for feature_dim 256 and an
    orthogonal initialisation (zero bias) of the encoder's Linear layer.

    Paper: PIE-G, https://arxiv.org/abs/2212.08860; RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.SVEALoss`; the encoder is PIE-G's
            :class:`~vigen.models.PIEGEncoder` (``make_loss("pieg", ..., encoder_weights=<file>)``).
        acting_batchnorm: ``"running"`` (RL-ViGen while training) or ``"observation"``, the BatchNorm
            statistics of the acting policy (see above).
        strong_augmentation, weak_weight, strong_weight, augment_next: the two views (see
            :class:`~vigen.losses.svea.TwoViewLoss`; RL-ViGen: the overlay, 0.5 each, the next
            observation shifted).
        **options: ``sampler`` (RL-ViGen: DrQ-v2's :class:`~vigen.losses.NoisyDeterministic`),
            ``augmentation`` (the weak view), ``target_encoder`` (RL-ViGen: none), ``input_mask``,
            ``param_groups``, ``channels_last``, ``reduction``, ``check_finite`` (see
            :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> import warnings
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Bounded
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import build_loss, example_batch
        >>> from vigen.models import Actor, Critic, PIEGEncoder
        >>> with warnings.catch_warnings():
        ...     warnings.simplefilter("ignore")  # no ImageNet weights here: random ResNet weights
        ...     encoder = PIEGEncoder(9, image_size=16, out_dim=32)
        >>> loss = build_loss("pieg", encoder, Actor(32, 2, hidden_dim=32), Critic(32, 2, hidden_dim=32))  # RL-ViGen's options
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4, observation_shape=(9, 16, 16))
        >>> out = loss(batch)
        >>> int(encoder.resnet.bn1.num_batches_tracked)  # three passes: next, clean and overlaid views
        3
        >>> sum(out[key] for key in ("loss_actor", "loss_critic")).backward()
        >>> encoder.resnet.conv1.weight.grad is None, encoder.fc.weight.grad is not None
        (True, True)
        >>> policy = loss.make_policy(Bounded(-1, 1, shape=(2,)))
        >>> policy(TensorDict({"pixels": batch["pixels"][0]}))["action"].shape, int(encoder.resnet.bn1.num_batches_tracked)
        (torch.Size([2]), 3)
    """

    own_out_keys = ("q_strong_mean",)

    def __init__(self, encoder: nn.Module, actor: nn.Module, critic: nn.Module, *, acting_batchnorm: BatchNormMode,
                 **options: Any) -> None:
        mode = _checked_mode(acting_batchnorm, type(self).__name__)
        super().__init__(encoder, actor, critic, **options)
        self.acting_batchnorm: BatchNormMode = mode

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        # the critic: SVEA's w·TD(s) + w̃·TD(s̃), each view in its own encoder pass (its own BatchNorm statistics);
        # the target's pass is the first of three
        critic = svea_critic(self, tensordict, batch, augment_next=self.augment_next, one_encoder_pass=False)
        loss_actor, log_prob = self.actor_loss(critic.features.detach())
        return self.output(tensordict, critic.target, *critic.weak_view_q,
                           {"loss_critic": critic.loss, "loss_actor": loss_actor,
                            **self.sampler.temperature_losses(log_prob, batch.action_dim, views=1)},
                           {**self.sampler.metrics(self.schedule_step, log_prob), "q_strong_mean": critic.q_strong_mean})

    def make_policy(
        self,
        action_spec: TensorSpec,
        *,
        pixels_key: NestedKey = "pixels",
        batchnorm: BatchNormMode | None = None,
    ) -> TensorDictModuleBase:
        """DrQ-v2's acting policy (:meth:`DrQv2Loss.make_policy`) with the encoder's BatchNorms in ``batchnorm`` mode.

        ``batchnorm`` (default: the loss's ``acting_batchnorm``): ``"running"`` normalises with
        the running statistics (RL-ViGen while training), ``"observation"`` with each
        observation's own frames (RL-ViGen's standalone evaluators). Acting never moves the
        running statistics.
        """
        mode = self.acting_batchnorm if batchnorm is None else _checked_mode(batchnorm, type(self).__name__)
        network = PixelsToAction(self)
        statistics = RunningStatistics(network) if mode == "running" else ObservationStatistics(network)
        return self.sampler.acting_module(statistics, action_spec, pixels_key, self.device)

    def reset_parameters_recursive(self) -> None:
        """Re-initialise the actor, the critic and what learns in the encoder; keep its frozen weights.

        The encoder's frozen parameters (the ImageNet ResNet) are kept as they are; a
        :class:`~vigen.models.PIEGEncoder` re-initialises its head with PyTorch's default (as
        RL-ViGen) and puts its BatchNorm statistics back to their values after loading.
        """
        frozen = {
            key: value.detach().clone()
            for key, value in self.encoder_params.items(True, True)
            if isinstance(value, nn.Parameter) and not value.requires_grad
        }
        super().reset_parameters_recursive()
        with torch.no_grad():
            for key, value in frozen.items():
                self.encoder_params.get(key).copy_(value)
            reset = getattr(self.encoder, "reset_parameters", None)
            if callable(reset):
                with self.encoder_params.to_module(self.encoder, preserve_module_state=False):
                    reset()


class ObservationStatistics(nn.Module):
    """Runs ``module`` one observation at a time, its BatchNorms on the statistics of that observation.

    Every BatchNorm in ``module`` runs in training mode (the statistics of the input, the
    ``k`` frames of one observation for a per-frame encoder), as RL-ViGen's and PIE-G's
    standalone evaluators run PIE-G; the running statistics and the modules' modes are put back
    afterwards, so acting leaves the encoder as it was. Pixels ``[..., C, H, W]``; ``module``
    returns one tensor per observation.

    Examples:
        >>> import torch
        >>> from torch import nn
        >>> net = ObservationStatistics(nn.Sequential(nn.Conv2d(3, 4, 3), nn.BatchNorm2d(4), nn.Flatten()))
        >>> net(torch.rand(2, 3, 8, 8)).shape, int(net.module[1].num_batches_tracked)
        (torch.Size([2, 144]), 0)
    """

    def __init__(self, module: nn.Module) -> None:
        super().__init__()
        self.module = module

    def forward(self, pixels: Tensor) -> Tensor:
        norms = [m for m in self.module.modules() if isinstance(m, BATCH_NORMS)]
        modes = [norm.training for norm in norms]
        saved = [[buffer.clone() for buffer in norm.buffers(recurse=False)] for norm in norms]
        for norm in norms:
            norm.train(True)
        try:
            batch = pixels.shape[:-3]
            observations = pixels.reshape(-1, *pixels.shape[-3:])
            out = torch.cat([self.module(observation.unsqueeze(0)) for observation in observations])
            return out.reshape(*batch, *out.shape[1:])
        finally:
            with torch.no_grad():
                for norm, mode, buffers in zip(norms, modes, saved):
                    norm.train(mode)
                    for buffer, value in zip(norm.buffers(recurse=False), buffers):
                        buffer.copy_(value)


def _checked_mode(mode: str, name: str) -> BatchNormMode:
    if mode not in ("running", "observation"):
        raise ValueError(
            f"{name}: the acting BatchNorm mode must be 'running' (running statistics, as RL-ViGen acts while "
            f"training) or 'observation' (each observation's own statistics, as its standalone evaluators), got {mode!r}."
        )
    return mode  # type: ignore[return-value]
