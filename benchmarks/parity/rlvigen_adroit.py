"""RL-ViGen's ViGen-adroit branch (https://github.com/gemcollector/RL-ViGen/tree/ViGen-adroit, ``src/``): VRL3."""

from __future__ import annotations

import warnings
from pathlib import Path

from benchmarks.parity.batchnorm_statistics import StatisticsGap
from benchmarks.parity.checkout import import_reference
from benchmarks.parity.harness import Batch, Case, ModuleMap, Setup, Views, replay_augmentation
from benchmarks.parity.rlvigen import CRITIC_MODULES, CRITIC_STEPS, DDPG_DEPARTURE, DDPG_METRICS, actor_and_critic, finish
from benchmarks.parity.stand_ins import torchvision_substitute

# RL-ViGen's thresholds (200 and 5) are not reached by a random initial network: lowered on both sides so that both
# branches of each run (default setup: 4 of the 8 targets above 0 compressed; 8 of the 32 pre-tanh outputs beyond 0.2)
VRL3_SAFE_Q_THRESHOLD = -1.0
VRL3_PRETANH_THRESHOLD = 0.2


def build_vrl3(reference: Path, setup: Setup) -> Case:
    from vigen.losses import NoisyDeterministic, build_loss
    from vigen.models import VRL3Encoder

    substitutes, notes = torchvision_substitute()
    ref = import_reference(reference, ["utils", "stage1_models", "transfer_util", "vrl3_agent"], paths=("", "algos"),
                           optional=("hydra", "omegaconf"), substitutes=substitutes)
    ref.notes.extend(notes)
    agent = ref.modules["vrl3_agent"].VRL3Agent(
        obs_shape=setup.obs_shape, action_shape=(setup.action_dim,), device="cpu", use_sensor=False, lr=setup.lr,
        feature_dim=setup.feature_dim, hidden_dim=setup.hidden_dim, critic_target_tau=0.01, num_expl_steps=0,
        update_every_steps=2, stddev_clip=0.3, use_tb=False, use_data_aug=True, encoder_lr_scale=1,
        stage1_model_name="resnet6_32channel", safe_q_target_factor=0.5, safe_q_threshold=VRL3_SAFE_Q_THRESHOLD,
        pretanh_penalty=0.001, pretanh_threshold=VRL3_PRETANH_THRESHOLD, stage2_update_encoder=True, cql_weight=1,
        cql_temp=1, cql_n_random=10, stage2_std=0.1, stage2_bc_weight=0, stage3_update_encoder=True, std0=0.01,
        std1=0.01, std_n_decay=500000, stage3_bc_lam0=0, stage3_bc_lam1=0.95,
    )
    agent.switch_to_RL_stages(verbose=False)  # its training script does this before stages 2 and 3
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # random initial weights, as RL-ViGen (stage1_use_pretrain=False)
        encoder = VRL3Encoder(setup.channels, max_value=255)
    loss = build_loss("vrl3", encoder, *actor_and_critic(setup, encoder.output_size),
                      augmentation=replay_augmentation(views.weak(), "shift"), safe_q_threshold=VRL3_SAFE_Q_THRESHOLD,
                      pretanh_threshold=VRL3_PRETANH_THRESHOLD, sampler=NoisyDeterministic(std_schedule=0.01, clip=0.3))
    loss = finish(loss, setup)
    modules = [ModuleMap("encoder.model", "encoder"), *CRITIC_MODULES]
    metrics = [*DDPG_METRICS, ("abs_pretanh", "abs_pretanh"), ("max_abs_pretanh", "max_abs_pretanh")]
    gap = StatisticsGap(agent, "encoder.model", "encoder", loss, batch.pixels, setup.step)
    departures = [
        DDPG_DEPARTURE + " Default setup: loss_actor 1.0e-1, ∂loss_actor up to 8.9e-1.",
        "RL-ViGen's Adroit config (use_sensor: true) feeds the actor and critic the hand's 24 joint positions next to "
        "the image features; vigen's loss is pixels only. The original runs here with use_sensor=False, its own "
        "pixel-only branch: the same math as zero joint positions (the trunks' 24 extra input columns would add "
        "nothing and get no gradient). With real joint positions the networks' inputs differ: nothing to compare.",
        "RL-ViGen fills its replay buffer with 25 demonstrations and runs stage 3 alone (train.sh: stage1_use_pretrain="
        "False, stage2_n_update=0); the demonstrations are data, not the update (both sides get the same synthetic "
        "batch), and its stage-3 BC weight stage3_bc_lam0 = 0 keeps its BC branch off (vigen has none). Without stage "
        "1 both encoders start from random weights (here the original's, copied), the one-frame stem tiled over the "
        "3 frames and divided by 3 (the original's switch_to_RL_stages(), VRL3Encoder's construction).",
        "encoder_lr_scale (RL-ViGen: 1; relocate 0.01) scales the encoder's Adam learning rate (RL-ViGen's "
        "encoder_opt, vigen's VRL3Loss.optimizer_groups): it changes the step, not any loss or gradient; 'steps "
        "taken' uses 1.",
        "σ = 0.01 on both sides (RL-ViGen: linear(0.01, 0.01, 500000), the same constant); the clip 0.3 is never "
        "reached at that σ.",
        f"safe_q_threshold {VRL3_SAFE_Q_THRESHOLD:g} and pretanh_threshold {VRL3_PRETANH_THRESHOLD:g} on both sides "
        "(RL-ViGen: 200, on Adroit rewards scaled by 1/20 to 1/100, and 5, which random initial networks never reach), "
        "so that in the default setup the safe target compresses 4 of the 8 targets and the penalty acts on 8 of the "
        "32 pre-tanh outputs; the penalty weight is RL-ViGen's 0.001.",
        "vigen encodes the next observation first (its target comes before the critic loss), RL-ViGen the current one: "
        "the same batch statistics, so the same outputs; the running statistics see the two batches in the other "
        "order (see 'measured').",
        "RL-ViGen's zero BC term is torch.FloatTensor([0]), a one-element float32 tensor: under the tool's float64 it "
        "would make the summed actor loss float32 by type promotion (its value rounded by 2.6e-8, gradients "
        "unchanged), so the tool builds it float64. In RL-ViGen's float32 training it changes nothing.",
    ]
    return Case("vrl3", agent, loss, modules, CRITIC_STEPS, {"aug": views.weak()}, [], [ref.modules["utils"]], metrics,
                departures, ref, batch, setup, update_kwargs={"stage": 3, "use_sensor": False}, measures=[gap],
                zero_gradients={"encoder.conv1.bias": "the stem's bias is followed by a training-mode BatchNorm, which "
                                "subtracts each channel's batch mean"})
