"""Augmentation-based actor-critic algorithms as TorchRL LossModules.

==========  ====================  =============================================================  ===========
name        loss                  what it adds to DrQ-v2's update                                paper
==========  ====================  =============================================================  ===========
``drqv2``   ``DrQv2Loss``         DDPG, clipped double-Q, n-step, random shift                   DrQ-v2
``svea``    ``SVEALoss``          TD loss on a strongly augmented view too (overlay)             SVEA
``srm``     ``SVEALoss`` record   SVEA with a frequency-masked overlay view                      SRM
``sgqn``    ``SGQNLoss``          saliency consistency term and an attribution head              SGQN
``curl``    ``CURLLoss``          InfoNCE over the batch with a bilinear head                    CURL
``drq``     ``DrQLoss``           (SAC) clean + shifted views, learned temperature               DrQ
``sada``    ``SADALoss``          (SAC) SVEA's critic; actor on clean + strong views             SADA
``vrl3``    ``VRL3Loss``          safe Q target, pre-tanh penalty, a fixed std, small ResNet   VRL3
``madi``    ``SVEALoss`` record   (SAC) SVEA behind a per-frame soft mask (critic-trained)       MaDi
``simgrl``  ``SVEALoss`` record   (SAC) SVEA with a shifted overlay, per-frame encoder           SimGRL
``pieg``    ``PIEGLoss``          SVEA on a frozen ImageNet ResNet-18 with adapting BNs          PIE-G
``scpl``    ``SCPLLoss``          (SAC) SVEA + masked-Q consistency, policy KL, dynamics         SCPL
==========  ====================  =============================================================  ===========

Each loss's ``forward`` is its paper's update, top to bottom, built from the pieces
:class:`ActorCriticLoss` writes once (the critic target, the TD loss, the actor loss, the output
and TorchRL's plumbing), and names every term of its summed loss. How it draws actions is its
``sampler``: :class:`NoisyDeterministic` (DrQ-v2's DDPG) or :class:`SquashedGaussian` (SAC, whose
temperature loss ``loss_alpha`` each ``forward`` adds with ``sampler.temperature_losses``); the
same object makes the acting policy explore, ``loss.make_policy(action_spec)`` (in vigen, "policy"
is always that acting module). Every default of a paper (the sampler and its options, the
augmentations, the coefficients, the optimizer groups) has one home, the algorithm's record in
:data:`ALGOS`: the loss classes take them as arguments, :func:`make_loss` and :func:`build_loss`
apply the record (:mod:`vigen.losses.paper_defaults` writes it out for help texts and docs).
Algorithms that differ only in their parts or options (SRM, MaDi, SimGRL) are records of an
existing class, not classes.

Each takes plain ``nn.Module`` networks (see :mod:`vigen.models`) and a TensorDict batch from a
TorchRL replay buffer, returns ``loss_*`` entries and detached metrics, and has target critic
parameters for ``torchrl.objectives.SoftUpdate`` (:class:`SplitSoftUpdate`: a rate per part, as DMC-GB's
SAC moves its encoder faster than its Q heads). :func:`make_loss` builds one by name with its paper's networks;
:class:`UpdateStep` is one update (steps of some parts on every N-th update only, as DMC-GB's actor).

Before any work a loss checks its batch: the pixels, the action, the next pixels, reward and
``terminated`` must be there (missing ones are named, with ``set_keys`` as the fix), and the
pixels must follow :mod:`vigen.pixel_format` at the encoder's ``max_value``. A NaN or inf loss
raises before it can reach an optimizer on the CPU, and is counted on the device elsewhere, where
raising would synchronize with the host (``loss.raise_if_nonfinite()``; ``check_finite=False``
turns the check off).
"""

from vigen.losses.base import ActorCriticLoss, example_batch, per_sample_mean, squared_td_errors, weighted_td_errors
from vigen.losses.curl import CURLLoss
from vigen.losses.drq import DrQLoss
from vigen.losses.drqv2 import DrQv2Loss
from vigen.losses.pieg import PIEGLoss
from vigen.losses.paper_defaults import defaults_help, defaults_markdown
from vigen.losses.registry import ALGOS, Algorithm, build_loss, make_loss, make_networks
from vigen.losses.samplers import (
    NoisyDeterministic,
    Sampler,
    SquashedGaussian,
    clipped_normal_sample,
    squashed_normal_sample,
)
from vigen.losses.sada import SADALoss
from vigen.losses.scpl import SCPLLoss, diagonal_gaussian_kl
from vigen.losses.saliency import GuidedBackprop, GuidedForward, SalientQLoss, attribution_mask
from vigen.losses.schedule import LinearSchedule
from vigen.losses.sgqn import SGQNLoss
from vigen.losses.svea import SVEALoss, TwoViewLoss, svea_critic
from vigen.losses.target_update import SplitSoftUpdate
from vigen.losses.update import UpdateStep, update_metrics
from vigen.losses.vrl3 import VRL3Loss

__all__ = [
    "ALGOS",
    "ActorCriticLoss",
    "Algorithm",
    "CURLLoss",
    "DrQLoss",
    "DrQv2Loss",
    "GuidedBackprop",
    "GuidedForward",
    "LinearSchedule",
    "NoisyDeterministic",
    "PIEGLoss",
    "SADALoss",
    "SCPLLoss",
    "SGQNLoss",
    "SalientQLoss",
    "SquashedGaussian",
    "SVEALoss",
    "Sampler",
    "SplitSoftUpdate",
    "TwoViewLoss",
    "UpdateStep",
    "VRL3Loss",
    "attribution_mask",
    "build_loss",
    "clipped_normal_sample",
    "defaults_help",
    "defaults_markdown",
    "diagonal_gaussian_kl",
    "example_batch",
    "make_loss",
    "make_networks",
    "per_sample_mean",
    "squared_td_errors",
    "squashed_normal_sample",
    "svea_critic",
    "update_metrics",
    "weighted_td_errors",
]
