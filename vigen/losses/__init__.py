"""Augmentation-based actor-critic algorithms as TorchRL LossModules.

====================  ==========================================================  ===========
loss                  what it adds to DrQ-v2's update                             paper
====================  ==========================================================  ===========
``DrQv2Loss``         (the base) DDPG, clipped double-Q, n-step, random shift       DrQ-v2
``SVEALoss``          TD loss on a strongly augmented view too (overlay)          SVEA
``SRMLoss``           SVEA with a frequency-masked overlay view                   SRM
``SGQNLoss``          saliency consistency term and an attribution head           SGQN
``CURLLoss``          InfoNCE over the batch with a bilinear head                 CURL
``DrQLoss``           (SAC instead) clean + shifted views, learned temperature     DrQ
``SADALoss``          (SAC) SVEA's critic; actor on clean + strong views           SADA
``VRL3Loss``          safe Q target, pre-tanh penalty, std 0.01, small ResNet     VRL3
``SACSVEALoss``       (SAC) SVEA as DMC-GB's code runs it: target encoder, ...   SVEA
``MaDiLoss``          (SAC) SVEA behind a per-frame soft mask (critic-trained)    MaDi
``SimGRLLoss``        (SAC) SVEA with a shifted overlay, per-frame encoder        SimGRL
``PIEGLoss``          SVEA on a frozen ImageNet ResNet-18 with adapting BNs       PIE-G
``SCPLLoss``          (SAC) SVEA + masked-Q consistency, policy KL, dynamics     SCPL
====================  ==========================================================  ===========

All of them run the steps of :class:`ActorCriticLoss` (:mod:`vigen.losses.base`) in DrQ-v2's
order: augment, critic target, critic loss, actor loss, auxiliary losses; a method changes named
hooks (its critic views, the actor's inputs, an input mask, extra terms). Each builds its acting
policy with ``loss.make_policy(action_spec)``.

Each takes plain ``nn.Module`` networks (see :mod:`vigen.models`) and a TensorDict batch from a
TorchRL replay buffer, returns ``loss_*`` entries and detached metrics, and has target critic
parameters for ``torchrl.objectives.SoftUpdate``. :func:`make_loss` builds one by name with its
paper's networks.

Before any work a loss checks its batch: the pixels, the action, the next pixels, reward and
``terminated`` must be there (missing ones are named, with ``set_keys`` as the fix), and the
pixels must follow :mod:`vigen.pixel_format` at the encoder's ``max_value``. A NaN or inf loss
raises before it can reach an optimizer (``check_finite=False`` turns that off).
"""

from vigen.losses.base import (
    ActorCriticLoss,
    ActorResult,
    AuxiliaryResult,
    CriticResult,
    Observations,
    View,
    td_error,
)
from vigen.losses.curl import CURLLoss
from vigen.losses.drq import DrQLoss
from vigen.losses.drqv2 import DrQv2Loss
from vigen.losses.madi import MaDiLoss
from vigen.losses.pieg import PIEGLoss
from vigen.losses.registry import ALGOS, make_loss
from vigen.losses.sac import SoftActorCritic
from vigen.losses.sada import SADALoss
from vigen.losses.scpl import SCPLLoss, diagonal_gaussian_kl
from vigen.losses.sampling import clipped_normal_sample, squashed_normal_sample
from vigen.losses.saliency import GuidedBackprop, attribution_mask
from vigen.losses.schedule import LinearSchedule
from vigen.losses.sgqn import SGQNLoss
from vigen.losses.simgrl import SimGRLLoss
from vigen.losses.srm import SRMLoss
from vigen.losses.svea import SVEALoss
from vigen.losses.svea_sac import SACSVEALoss
from vigen.losses.update import UpdateStep, update_metrics
from vigen.losses.vrl3 import VRL3Loss

__all__ = [
    "ALGOS",
    "ActorCriticLoss",
    "ActorResult",
    "AuxiliaryResult",
    "CriticResult",
    "Observations",
    "View",
    "td_error",
    "CURLLoss",
    "DrQLoss",
    "DrQv2Loss",
    "GuidedBackprop",
    "LinearSchedule",
    "MaDiLoss",
    "PIEGLoss",
    "SACSVEALoss",
    "SADALoss",
    "SCPLLoss",
    "SGQNLoss",
    "SimGRLLoss",
    "SoftActorCritic",
    "SRMLoss",
    "SVEALoss",
    "UpdateStep",
    "VRL3Loss",
    "attribution_mask",
    "clipped_normal_sample",
    "diagonal_gaussian_kl",
    "make_loss",
    "squashed_normal_sample",
    "update_metrics",
]
