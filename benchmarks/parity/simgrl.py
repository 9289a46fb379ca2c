"""SimGRL (https://github.com/W-Song11/SimGRL-Code), a fork of DMC-GB."""

from __future__ import annotations

from pathlib import Path

from benchmarks.parity.dmcgb import (DMCGB_DEPARTURES, SAC_STEPS, DMCGBDriver, cuda_is_cpu, dmcgb_args, dmcgb_maps,
                                     import_dmcgb_fork, load_original_weights, sac_networks)
from benchmarks.parity.harness import Batch, Case, ModuleMap, Pairs, Setup, Views, replay_augmentation


def build_simgrl(reference: Path, setup: Setup) -> Case:
    from vigen.losses import build_loss
    from vigen.models import PerFrameEncoder
    from vigen.transforms import RandomShiftedOverlay

    ref = import_dmcgb_fork(reference, "simgrl")
    module = ref.modules["algorithms.simgrl"]
    with cuda_is_cpu():
        driver = DMCGBDriver(module.SimGRL(setup.obs_shape, (setup.action_dim,), dmcgb_args(setup, algorithm="simgrl")))
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    shifted_overlay = RandomShiftedOverlay(alpha=0.5, max_shift=6, max_value=255, seed=setup.seed + 140)
    overlay_pairs: Pairs = [(views.obs, shifted_overlay.augment(views.obs))]
    networks = sac_networks(PerFrameEncoder(setup.channels, max_value=255, centered=False), setup)
    frame = tuple((str(2 + 2 * i), str(2 * i)) for i in range(3))  # CenterCrop, NormalizeImg, conv, ReLU, conv, ...
    maps = dmcgb_maps([ModuleMap("agent.critic.encoder.shared_cnn.layers", "encoder.frame_net", frame),
                        ModuleMap("agent.critic.encoder.shared_cnn.layers2", "encoder.stack_net")])
    load_original_weights(networks, maps, driver)
    loss = build_loss("simgrl", *networks.values(), init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"),
                      strong_augmentation=replay_augmentation(overlay_pairs, "shifted overlay"))
    loss.make_value_estimator(gamma=setup.gamma)
    departures = [*DMCGB_DEPARTURES,
                  "Strong view: vigen's RandomShiftedOverlay of the shifted observation (each frame its own shifted crop "
                  "of the image), replayed to both sides (SimGRL's from Places365); obs and next obs shifted on both "
                  "sides (its sample_drq)."]
    return Case("simgrl", driver, loss, maps, SAC_STEPS, {"aug": views.weak()},
                [(ref.modules["augmentations"], "random_overlay_shift", overlay_pairs)], [module],
                [("alpha", "train_alpha/value")], departures, ref, batch, setup)
