"""RL-ViGen master (https://github.com/gemcollector/RL-ViGen): DrQ-v2, SVEA, SRM, CURL, SGQN, DrQ and PIE-G.

Also the DDPG pieces (agent arguments, actor and critic heads, maps, steps, departure) that SADA's
and VRL3's cases reuse.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import torch
from torch import nn

from benchmarks.parity.batchnorm_statistics import StatisticsGap
from benchmarks.parity.checkout import Reference, import_reference
from benchmarks.parity.harness import Batch, Case, ModuleMap, Pairs, Setup, StepMap, Views, replay_augmentation
from benchmarks.parity.stand_ins import captum_substitute, imagenet_stand_in, torchvision_substitute


RLVIGEN_OPTIONAL = ("hydra", "omegaconf", "torchvision", "torchvision.transforms", "torchvision.datasets",
                    "torchvision.utils", "kornia")
DDPG_DEPARTURE = (
    "RL-ViGen computes the actor loss after its critic/encoder Adam step; vigen's actor loss sees the critic "
    "before the step (TorchRL's DDPG). Compared at the same parameters (steps recorded, not taken); "
    "'steps taken' shows the effect of the order."
)
CRITIC_STEPS = [
    StepMap("critic", "loss_critic", (("critic_opt", 0), ("encoder_opt", 0))),
    StepMap("actor", "loss_actor", (("actor_opt", 0),)),
]
CRITIC_MODULES = [
    ModuleMap("actor", "actor", (("policy", "action_head"),)),  # DrQ-v2's actor calls its MLP policy
    ModuleMap("critic", "critic", (("Q1", "q1"), ("Q2", "q2"))),
]
DDPG_METRICS = [("target_mean", "critic_target_q"), ("q_mean", "critic_q1")]


def _rlvigen(reference: Path, names: Sequence[str], captum: bool = False) -> Reference:
    substitutes, notes = captum_substitute() if captum else ({}, [])
    ref = import_reference(reference, names, paths=("", "algos"), optional=RLVIGEN_OPTIONAL, substitutes=substitutes)
    ref.notes.extend(notes)
    return ref


def agent_kwargs(setup: Setup) -> dict[str, Any]:
    return dict(
        obs_shape=setup.obs_shape, action_shape=(setup.action_dim,), device="cpu", lr=setup.lr,
        feature_dim=setup.feature_dim, hidden_dim=setup.hidden_dim, critic_target_tau=0.01, num_expl_steps=2000,
        update_every_steps=2, stddev_schedule="linear(1.0,0.1,100000)", stddev_clip=0.3, use_tb=True,
    )


def actor_and_critic(setup: Setup, repr_dim: int) -> tuple[nn.Module, nn.Module]:
    from vigen.models import Actor, Critic

    return (Actor(repr_dim, setup.action_dim, setup.feature_dim, setup.hidden_dim),
            Critic(repr_dim, setup.action_dim, setup.feature_dim, setup.hidden_dim))


def ddpg_options() -> dict[str, Any]:
    from vigen.losses import LinearSchedule, NoisyDeterministic

    return dict(sampler=NoisyDeterministic(std_schedule=LinearSchedule(1.0, 0.1, 100_000), clip=0.3))


def finish(loss: Any, setup: Setup) -> Any:
    loss.make_value_estimator(gamma=setup.gamma)
    loss.set_step(setup.step)
    return loss


def build_drqv2(reference: Path, setup: Setup) -> Case:
    from vigen.losses import build_loss
    from vigen.models import DrQv2Encoder

    ref = _rlvigen(reference, ["utils", "drqv2"])
    agent = ref.modules["drqv2"].DrQV2Agent(**agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    encoder = DrQv2Encoder(setup.channels, max_value=255)
    loss = build_loss("drqv2", encoder, *actor_and_critic(setup, 32 * 35 * 35),
                      augmentation=replay_augmentation(views.weak(), "shift"), **ddpg_options())
    return Case("drqv2", agent, finish(loss, setup), [ModuleMap("encoder", "encoder"), *CRITIC_MODULES], CRITIC_STEPS,
                {"aug": views.weak()}, [], [ref.modules["utils"]], DDPG_METRICS, [DDPG_DEPARTURE], ref, batch, setup)


def _svea_like(reference: Path, setup: Setup, name: str) -> Case:
    from vigen.losses import build_loss
    from vigen.models import SharedCNN

    ref = _rlvigen(reference, ["utils", "svea", "srm"])
    module = ref.modules[name]
    agent = (module.SRMAgent if name == "srm" else module.SVEAAgent)(**agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    overlaid = views.overlay(0, views.obs)
    overlay_pairs: Pairs = [(views.obs, overlaid)]
    module_views = [(module, "random_overlay", overlay_pairs)]
    strong = [replay_augmentation(overlay_pairs, "overlay")]
    departures = [
        DDPG_DEPARTURE,
        "vigen rounds the overlay blend of uint8 frames to uint8 (RL-ViGen blends floats); the views here are float "
        "and replayed to both sides, so the rounding is not exercised.",
    ]
    if name == "srm":
        masked = views.srm(overlaid)
        mask_pairs: Pairs = [(overlaid, masked)]
        module_views.append((module, "random_mask_freq_v2", mask_pairs))
        strong.append(replay_augmentation(mask_pairs, "frequency mask"))
        departures.append("RL-ViGen's frequency mask is not clamped to [0, 255] and applies with p=0.5 per batch; the "
                          "replayed view is vigen's RandomFrequencyMask(p=1) draw (clamped), given to both sides.")
    encoder = SharedCNN(setup.channels, max_value=255)
    loss = build_loss(name, encoder, *actor_and_critic(setup, 32 * 21 * 21),
                      augmentation=replay_augmentation(views.weak(), "shift"), strong_augmentation=strong, **ddpg_options())
    modules = [ModuleMap("encoder", "encoder", (("layers", "convnet"),)), *CRITIC_MODULES]
    return Case(name, agent, finish(loss, setup), modules, CRITIC_STEPS, {"aug": views.weak()}, module_views,
                [ref.modules["utils"]], DDPG_METRICS, departures, ref, batch, setup)


def build_svea(reference: Path, setup: Setup) -> Case:
    return _svea_like(reference, setup, "svea")


def build_srm(reference: Path, setup: Setup) -> Case:
    return _svea_like(reference, setup, "srm")


def build_curl(reference: Path, setup: Setup) -> Case:
    from vigen.losses import build_loss
    from vigen.models import CURLHead, ProjectedEncoder

    ref = _rlvigen(reference, ["utils", "drqv2", "drq", "curl"])
    agent = ref.modules["curl"].CURLAgent(aux_lr=1e-4, aux_beta=0.99, **agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    anchor, positive = views.shift(0), views.shift(1)
    contrastive: Pairs = [(batch.pixels, anchor), (batch.pixels, positive)]
    original_order = views.weak() + contrastive  # obs, next_obs, anchor, positive: the order of CURLAgent.update
    encoder = ProjectedEncoder(setup.channels, image_size=setup.image_size, max_value=255)
    loss = build_loss("curl", encoder, *actor_and_critic(setup, 512), CURLHead(512),
                      augmentation=replay_augmentation(views.weak(), "shift"),
                      contrastive_augmentation=replay_augmentation(contrastive, "contrastive shift"), **ddpg_options())
    modules = [ModuleMap("encoder", "encoder", (("projector", "projection"),)), ModuleMap("curl_head", "head"), *CRITIC_MODULES]
    steps = CRITIC_STEPS + [StepMap("curl", "loss_curl", (("curl_optimizer", 0), ("encoder_opt", 1)))]
    departures = [
        DDPG_DEPARTURE,
        "RL-ViGen encodes the contrastive anchor after the critic step and steps the encoder a second time "
        "(encoder_opt, plus curl_optimizer with betas (0.99, 0.999)); vigen takes loss_curl from the same "
        "parameters as loss_critic, in one backward. Compared: ∂loss_curl against the gradients of that second "
        "step, at unchanged parameters ('steps taken': after the critic step).",
        "Positives come from the online encoder without gradient on both sides (no momentum key encoder).",
    ]
    return Case("curl", agent, finish(loss, setup), modules, steps, {"aug": original_order}, [], [ref.modules["utils"]],
                DDPG_METRICS, departures, ref, batch, setup)


def build_sgqn(reference: Path, setup: Setup) -> Case:
    from vigen.losses import build_loss
    from vigen.models import AttributionDecoder, ProjectedEncoder

    ref = _rlvigen(reference, ["utils", "rl_utils", "drqv2", "sgqn"], captum=True)
    module = ref.modules["sgqn"]
    agent = module.SGQNAgent(aux_lr=1e-4, aux_beta=0.99, sgqn_quantile=0.93, **agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    overlay_pairs: Pairs = [(views.obs, views.overlay(0, views.obs))]
    encoder = ProjectedEncoder(setup.channels, image_size=setup.image_size, max_value=255)
    decoder = AttributionDecoder(setup.action_dim, embedding_dim=512, image_size=setup.image_size)
    loss = build_loss("sgqn", encoder, *actor_and_critic(setup, 512), decoder, quantile=0.93, consistency_weight=0.9,
                      augmentation=replay_augmentation(views.weak(), "shift"),
                      attribution_augmentation=replay_augmentation(overlay_pairs, "overlay"), **ddpg_options())
    modules = [ModuleMap("encoder", "encoder", (("projector", "projection"),)),
               ModuleMap("attribution_predictor.decoder", "decoder"), *CRITIC_MODULES]
    steps = CRITIC_STEPS + [StepMap("attribution", "loss_attribution", (("aux_optimizer", 0),))]
    departures = [
        DDPG_DEPARTURE,
        "RL-ViGen recomputes the guided-backprop mask after the critic step and trains the attribution head "
        "with its own Adam over encoder + decoder (aux_lr, betas (0.99, 0.999)); vigen uses the mask of the "
        "critic step and one backward. At unchanged parameters both masks are the same; 'steps taken' shows "
        "the recomputed mask's effect.",
        "The fill of non-salient pixels is one scalar U(min s, max s) on both sides (the same u).",
    ]
    return Case("sgqn", agent, finish(loss, setup), modules, steps, {"aug": views.weak()},
                [(module, "random_overlay", overlay_pairs)], [ref.modules["utils"], module], DDPG_METRICS, departures,
                ref, batch, setup)


def build_drq(reference: Path, setup: Setup) -> Case:
    from vigen.losses import SquashedGaussian, build_loss
    from vigen.models import Critic, DrQv2Encoder, GaussianActor

    ref = _rlvigen(reference, ["utils", "drq"])
    kwargs = agent_kwargs(setup)
    kwargs["use_tb"] = False  # its metrics call SquashedNormal.entropy(), which torch does not implement
    agent = ref.modules["drq"].DrQAgent(init_temperature=0.1, log_std_bounds=[-10, 2], hidden_depth=2, **kwargs)
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    repr_dim = 32 * 35 * 35
    loss = build_loss("drq", DrQv2Encoder(setup.channels, max_value=255),
                      GaussianActor(repr_dim, setup.action_dim, setup.hidden_dim, hidden_depth=2, log_std_bounds=(-10.0, 2.0)),
                      Critic(repr_dim, setup.action_dim, setup.feature_dim, setup.hidden_dim),
                      sampler=SquashedGaussian(init_temperature=0.1), augmentation=replay_augmentation(views.weak(), "shift"))
    loss.make_value_estimator(gamma=setup.gamma)
    modules = [ModuleMap("encoder", "encoder"), ModuleMap("actor", "actor", (("trunk", "action_head"),)),
               ModuleMap("critic", "critic", (("Q1", "q1"), ("Q2", "q2"))), ModuleMap("log_alpha", "sampler.log_alpha")]
    steps = [
        StepMap("critic", "loss_critic", (("critic_opt", 0), ("encoder_opt", 0))),
        StepMap("actor", "loss_actor", (("actor_opt", 0),)),
        StepMap("alpha", "loss_alpha", (("log_alpha_optimizer", 0),)),
    ]
    departures = [
        "Like RL-ViGen (and unlike the original DrQ's K = M = 2 shifted views), vigen's default pairs the raw "
        "view with one shifted view; DrQLoss(clean_view=False, target_encoder=True) is the original DrQ and is "
        "not compared here.",
        "RL-ViGen computes the actor and temperature losses after its critic step; compared at the same "
        "parameters ('steps taken' shows the order's effect). nstep = 1 as in RL-ViGen's DrQ config.",
    ]
    return Case("drq", agent, loss, modules, steps, {"aug": views.weak()}, [], [ref.modules["utils"]], [],
                departures, ref, batch, setup)


def build_pieg(reference: Path, setup: Setup) -> Case:
    from vigen.losses import build_loss
    from vigen.models import PIEGEncoder

    imagenet = imagenet_stand_in(setup.seed + 200)
    substitutes, notes = torchvision_substitute(imagenet)
    ref = import_reference(reference, ["utils", "pieg"], paths=("", "algos"), optional=RLVIGEN_OPTIONAL, substitutes=substitutes)
    ref.notes.extend(notes)
    module = ref.modules["pieg"]
    agent = module.PIEGAgent(**agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    overlay_pairs: Pairs = [(views.obs, views.overlay(0, views.obs))]
    with tempfile.TemporaryDirectory() as folder:  # vigen loads torchvision's state dict from a file
        weights = Path(folder) / "resnet18.pth"
        torch.save(imagenet.state_dict(), weights)
        encoder = PIEGEncoder(setup.channels, image_size=setup.image_size, out_dim=agent.encoder.repr_dim, weights=weights,
                              max_value=255)
    loss = build_loss("pieg", encoder, *actor_and_critic(setup, encoder.out_dim),
                      augmentation=replay_augmentation(views.weak(), "shift"),
                      strong_augmentation=replay_augmentation(overlay_pairs, "overlay"), **ddpg_options())
    loss = finish(loss, setup)
    resnet = [ModuleMap(f"encoder.model.{name}", f"encoder.resnet.{name}") for name in ("conv1", "bn1", "layer1", "layer2")]
    modules = [*resnet, ModuleMap("encoder.fc", "encoder.fc"), ModuleMap("encoder.ln", "encoder.ln"), *CRITIC_MODULES]
    gap = StatisticsGap(agent, "encoder.model", "encoder.resnet", loss, batch.pixels, setup.step)
    departures = [
        DDPG_DEPARTURE + " Default setup: loss_actor 5.6e-2, ∂loss_actor up to 3.5e-1.",
        "RL-ViGen's ResEncoder measures its output size with a training-mode forward pass of 32 random-normal stacks "
        "while it is built, which moves its BatchNorm running statistics one momentum step (0.1) from the loaded "
        "weights' towards that noise's; vigen's start at the loaded values. They are left different here: the update "
        "normalises with batch statistics, so no loss or gradient depends on them (confirmed by the rows above); they "
        "matter when acting (running statistics), until the gap fades (× 0.9 per encoder pass, 3 per update: below "
        "1e-6 of it after 44 updates): see 'measured'.",
        "vigen encodes the next view first (its target comes before the critic loss), then the clean and the overlaid "
        "view, one pass each; RL-ViGen encodes clean, overlaid, next. Same batch statistics, so the same outputs; the "
        "running statistics see the three batches in another order (see 'measured').",
        "The ResNet's weights are frozen on both sides (no gradient; RL-ViGen's encoder_opt holds them but they get "
        "none); only the encoder's Linear and LayerNorm learn, from the critic loss.",
        "vigen rounds the overlay blend of uint8 frames to uint8 (RL-ViGen blends floats); the views here are float "
        "and replayed to both sides, so the rounding is not exercised.",
        "RL-ViGen's ViGen-adroit branch runs PIE-G on VRL3's stage-3 update (safe Q target, std 0.01, feature_dim 256, "
        "hand joint positions); this row is the master branch's agent (DMC, robosuite), which PIEGLoss implements.",
    ]
    return Case("pieg", agent, loss, modules, CRITIC_STEPS, {"aug": views.weak()}, [(module, "random_overlay", overlay_pairs)],
                [ref.modules["utils"]], DDPG_METRICS, departures, ref, batch, setup, measures=[gap])
