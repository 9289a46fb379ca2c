"""DrQ-v2's update: DDPG with a clipped double-Q target, n-step returns and random shifts."""

from __future__ import annotations

from tensordict import TensorDictBase
from tensordict.nn import dispatch

from vigen.losses.base import ActorCriticLoss, squared_td_errors


class DrQv2Loss(ActorCriticLoss):
    """DrQ-v2's update: DDPG with a clipped double-Q target, n-step returns and random shifts.

    One call computes, on a replay-buffer batch:

    * ``loss_critic`` = MSE(Q1(h, a), y) + MSE(Q2(h, a), y) with ``h = encoder(shift(obs))`` and
      ``y = r + γⁿ·(1 − terminated)·min(Q1', Q2')(h', a')``, where ``h' = encoder(shift(next obs))``
      is computed without gradient by the *online* encoder, ``Q'`` is the target critic and
      ``a' = actor(h')`` plus clipped Gaussian noise (std from the schedule, clip 0.3). Time-limit
      truncations bootstrap, terminations do not; ``γⁿ`` uses ``steps_to_next_obs`` when the
      batch has it (TorchRL's ``MultiStepTransform``).
    * ``loss_actor`` = −min(Q1, Q2)(h.detach(), actor(h.detach()) + noise), through a detached
      critic: it trains the actor only.

    The encoder learns from the critic loss only; only the critic has target parameters
    (``target_critic_params``), moved by ``SoftUpdate(loss, tau=0.01)``. Since the gradients do
    not cross, one ``backward()`` of the sum of the ``loss_*`` entries and a step of every
    optimizer equals DrQ-v2's separate updates, except that the actor sees the critic before
    (not after) this step's update, as in TorchRL's DDPG/TD3.

    The noise is the loss's ``sampler``, :class:`~vigen.losses.NoisyDeterministic`: its std follows
    its ``std_schedule`` at the step given to :meth:`set_step` (DrQ-v2: agent steps), and it makes the
    acting policy explore (:meth:`make_policy`). With SAC's :class:`~vigen.losses.SquashedGaussian`
    (and an actor returning mean and log σ) the same update is SAC's, with its ``loss_alpha``. The
    batch contract and the finite-loss check are :class:`~vigen.losses.ActorCriticLoss`'s. The
    class has no options of its own: ``make_loss("drqv2")`` gives it DrQ-v2's (the record
    ``ALGOS["drqv2"]``: the sampler, ``RandomShift(pad=4)``).

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Args:
        encoder: pixels ``[B, 3·k, H, W]`` → features ``[B, D]``, e.g. :class:`~vigen.models.DrQv2Encoder`.
        actor: features → action mean in [-1, 1], e.g. :class:`~vigen.models.Actor`.
        critic: (features, action) → (Q1, Q2), e.g. :class:`~vigen.models.Critic`.
        sampler: the noise, ``NoisyDeterministic(std_schedule, clip)`` (DrQ-v2: ``linear(1.0, 0.1,
            100000)``, clip 0.3, its defaults), or :class:`~vigen.losses.SquashedGaussian`.
        augmentation: the weak augmentation, drawn independently for obs and next obs (DrQ-v2:
            ``RandomShift(pad=4)``); ``None`` if the replay buffer already augments.
        target_encoder: score the next action on a target encoder's features (DrQ-v2: ``False``).
        **options: ``input_mask``, ``param_groups``, ``channels_last``, ``reduction``, ``check_finite``
            (see :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import NoisyDeterministic, example_batch
        >>> from vigen.models import Actor, Critic, DrQv2Encoder
        >>> from vigen.transforms import RandomShift
        >>> encoder = DrQv2Encoder(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = DrQv2Loss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32),
        ...                  sampler=NoisyDeterministic(), augmentation=RandomShift(pad=4), target_encoder=False)
        >>> loss.make_value_estimator(gamma=0.99)
        DrQv2Loss(...)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_critic']
        >>> sum(out[key] for key in ("loss_actor", "loss_critic")).backward()
        >>> loss(batch.exclude(("next", "terminated")))
        Traceback (most recent call last):
        ...
        KeyError: "DrQv2Loss: the batch has no ('next', 'terminated')...
    """

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        obs, next_obs = self.augment(batch.pixels), self.augment(batch.next_pixels)
        target = self.critic_target(tensordict, next_obs)
        features = self.encode(obs)
        q1, q2 = self.q_values(features, batch.action)
        loss_actor, log_prob = self.actor_loss(features.detach())
        return self.output(tensordict, target, q1, q2,
                           {"loss_critic": squared_td_errors(q1, q2, target), "loss_actor": loss_actor,
                            **self.sampler.temperature_losses(log_prob, batch.action_dim, views=1)},
                           self.sampler.metrics(self.schedule_step, log_prob))
