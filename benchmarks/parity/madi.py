"""MaDi (https://github.com/bramgrooten/mask-distractions), a fork of DMC-GB."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from benchmarks.parity.dmcgb import (DMCGB_DEPARTURES, SAC_STEPS, DMCGBDriver, cuda_is_cpu, dmcgb_args, dmcgb_maps,
                                     import_dmcgb_fork, load_original_weights, sac_networks, shared_cnn_map)
from benchmarks.parity.harness import Batch, Case, ModuleMap, Pairs, Setup, StepMap, Views, replay_augmentation


class _NoRecorder:
    """MaDi's ``AugmentationRecorder``: records nothing."""

    def record(self, *args: Any, **kwargs: Any) -> None:
        pass


def build_madi(reference: Path, setup: Setup) -> Case:
    from vigen.losses import build_loss
    from vigen.models import MaDiMasker, SharedCNN

    ref = import_dmcgb_fork(reference, "madi")
    module = ref.modules["algorithms.madi"]
    args = dmcgb_args(setup, algorithm="madi", svea_alpha=0.5, svea_beta=0.5, augment="overlay", overlay_alpha=0.5,
                       masker_lr=1e-3, masker_beta=0.9, masker_num_layers=3, masker_num_filters=32, mask_type="soft",
                       mask_threshold=0.5, mask_threshold_type="fix", encoder="cnn")
    with cuda_is_cpu():
        driver = DMCGBDriver(module.MaDi(setup.obs_shape, (setup.action_dim,), args, _NoRecorder()))
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    overlay_pairs: Pairs = [(views.obs, views.overlay(0, views.obs))]
    networks = sac_networks(SharedCNN(setup.channels, max_value=255, centered=False), setup)
    masker = MaDiMasker(num_filters=32, max_value=255)
    networks["input_mask"] = masker  # the madi preset puts it in front of the encoder
    maps = dmcgb_maps([shared_cnn_map("agent.critic.encoder.shared.layers", "encoder.convnet")])  # MaDi renames shared_cnn
    maps.append(ModuleMap("agent.masker.layers", "input_mask.net", (("2", "0"), ("4", "2"), ("6", "4"))))
    load_original_weights(networks, maps, driver)
    loss = build_loss("madi", *networks.values(), init_temperature=0.1,
                      augmentation=replay_augmentation(views.weak(), "shift"),
                      strong_augmentation=replay_augmentation(overlay_pairs, "overlay"))
    loss.make_value_estimator(gamma=setup.gamma)
    steps = [StepMap("critic", "loss_critic", (("critic_optimizer", 0), ("masker_optimizer", 0))), *SAC_STEPS[1:]]
    departures = [*DMCGB_DEPARTURES,
                  "MaDi's masker steps with the critic (its own Adam, lr 1e-3, β1 0.9): vigen's optimizer_groups gives it "
                  "the same group; compared as one step with the critic.",
                  "Strong view: vigen's RandomOverlay of the shifted observation, replayed to both sides (MaDi's from "
                  "Places365); the next observation is not shifted on either side (DMC-GB's sample_svea)."]
    return Case("madi", driver, loss, maps, steps, {"aug": views.weak()}, [(module, "strong_augment", overlay_pairs)],
                [module], [("alpha", "train_alpha/value")], departures, ref, batch, setup)
