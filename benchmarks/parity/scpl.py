"""SCPL (https://github.com/bofusun/SCPL), a fork of DMC-GB."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import torch

from benchmarks.parity.dmcgb import (DMCGB_DEPARTURES, SAC_STEPS, DMCGBDriver, dmcgb_args, dmcgb_maps,
                                     import_dmcgb_fork, load_original_weights, sac_networks, shared_cnn_map)
from benchmarks.parity.harness import Batch, Case, ModuleMap, Pairs, Setup, StepMap, Views, replay_augmentation


def build_scpl(reference: Path, setup: Setup) -> Case:
    from vigen.losses import build_loss
    from vigen.models import LatentDynamics, SharedCNN

    ref = import_dmcgb_fork(reference, "SCPL")
    ref.notes.append("torch.utils.tensorboard.SummaryWriter is a stand-in that writes nothing")
    module = ref.modules["algorithms.SCPL"]
    with contextlib.redirect_stdout(io.StringIO()):  # its transition model prints a line when built
        driver = DMCGBDriver(module.SCPL(setup.obs_shape, (setup.action_dim,), dmcgb_args(setup, algorithm="scpl")))
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    pair = torch.cat([views.obs, views.next_obs], dim=1)  # SCPL overlays obs and next obs stacked on the channels
    overlay_pairs: Pairs = [(pair, views.overlay(0, pair))]
    networks = sac_networks(SharedCNN(setup.channels, max_value=255, centered=False), setup)
    networks["dynamics"] = LatentDynamics(setup.feature_dim, setup.action_dim)
    maps = dmcgb_maps([shared_cnn_map("agent.critic.encoder.shared_cnn.layers", "encoder.convnet")])
    maps.append(ModuleMap("agent.transition_model", "dynamics",
                          (("fc_mu", "next_embedding"), ("fc_reward", "reward"), ("fc", "hidden"), ("ln", "norm"))))
    load_original_weights(networks, maps, driver)
    loss = build_loss("scpl", *networks.values(), init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"),
                    strong_augmentation=replay_augmentation(overlay_pairs, "overlay"))
    loss.make_value_estimator(gamma=setup.gamma)
    steps = [*SAC_STEPS, StepMap("dynamics", "loss_dynamics", (("encoder_optimizer", 0), ("decoder_optimizer", 0)))]
    metrics = [("policy_kl", "train/kl_loss"), ("reward_error", "train_ae/reward_loss"),
               ("loss_dynamics", "train_ae/transition_loss"), ("alpha", "train_alpha/value")]
    departures = [
        *DMCGB_DEPARTURES,
        "After its actor step SCPL steps the encoder (with the critic's projection) and the dynamics model with their "
        "own Adam (lr 3e-4), every second update (aux_update_freq 2; it runs at the step compared).",
        "SCPL computes two more saliency maps (after the critic step, and of the next observation in the model step) "
        "and samples two more actions that nothing uses; vigen does not (the draw counts above say so).",
        "Strong views: one overlay of obs and next obs stacked on the channels (the same image for both), drawn "
        "with vigen's RandomOverlay and replayed to both sides; SCPL's comes from Places365 on float pixels.",
    ]
    unused = 3 * setup.batch_size * setup.action_dim  # actor(aug_obs) in the actor step, actor(next obs of both views) in the model step
    return Case("scpl", driver, loss, maps, steps, {"aug": views.weak()},
                [(ref.modules["augmentations"], "random_overlay", overlay_pairs)], [module], metrics, departures,
                ref, batch, setup, unused_normals=unused)
