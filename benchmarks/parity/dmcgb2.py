"""DMC-GB2 (https://github.com/aalmuzairee/dmcgb2, main): SADA."""

from __future__ import annotations

from pathlib import Path

from benchmarks.parity.checkout import import_reference
from benchmarks.parity.harness import Batch, Case, ModuleMap, Pairs, Setup, StepMap, Views, replay_augmentation
from benchmarks.parity.rlvigen import agent_kwargs

DMCGB2_OPTIONAL = ("torchvision", "torchvision.transforms", "torchvision.datasets")


def build_sada(reference: Path, setup: Setup) -> Case:
    from vigen.losses import make_loss
    from vigen.transforms import DMCGB2_AUGMENTATIONS, dmcgb2_strong_augmentation

    ref = import_reference(reference, ["utils", "augmentations", "sada"], paths=("", "algos"), optional=DMCGB2_OPTIONAL)
    kwargs = agent_kwargs(setup)
    for option in ("stddev_schedule", "stddev_clip", "use_tb"):
        del kwargs[option]
    # strong_augs only builds the callable that the replay replaces; "overlay" builds without torchvision
    agent = ref.modules["sada"].AGENT(init_temperature=0.1, log_std_bounds=[-10, 2], strong_augs=["overlay"], **kwargs)
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    strong, twin = (dmcgb2_strong_augmentation("all", seed=setup.seed + 130) for _ in range(2))
    strong.max_value = twin.max_value = 255
    strong_pairs: Pairs = [(views.obs, strong.augment(views.obs))]
    drawn = sorted({DMCGB2_AUGMENTATIONS[int(i)] for i in twin.make_params(views.obs)["choice"]}, key=DMCGB2_AUGMENTATIONS.index)
    # make_loss builds DMC-GB2's networks: DrQ-v2's encoder, the LayerNorm-trunk twin critic, the SAC actor on a trunk
    loss = make_loss("sada", setup.obs_shape, setup.action_dim, feature_dim=setup.feature_dim, hidden_dim=setup.hidden_dim,
                     max_value=255, init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"),
                     strong_augmentation=replay_augmentation(strong_pairs, "strong"))
    loss.make_value_estimator(gamma=setup.gamma)
    modules = [ModuleMap("encoder", "encoder"), ModuleMap("actor", "actor", (("policy", "action_head"),)),
               ModuleMap("critic", "critic", (("Q1", "q1"), ("Q2", "q2"))), ModuleMap("log_alpha", "sampler.log_alpha")]
    steps = [
        StepMap("critic", "loss_critic", (("critic_opt", 0), ("encoder_opt", 0))),
        StepMap("actor", "loss_actor", (("actor_opt", 0),)),
        StepMap("alpha", "loss_alpha", (("log_alpha_optimizer", 0),)),
    ]
    metrics = [("target_mean", "critic_target_q"), ("q_mean", "reg_critic_q1"), ("q_strong_mean", "aug_critic_q1"),
               ("entropy", "actor_entropy"), ("alpha", "alpha_value")]
    departures = [
        "DMC-GB2 computes the actor and temperature losses after its critic/encoder Adam step (the actor then reads "
        "the stepped critic); vigen's come from the same parameters as loss_critic. Compared at unchanged "
        "parameters; 'steps taken' shows the order's effect (default setup: loss_actor 1.4e-1, ∂loss_actor up to "
        "1.1e-1; loss_alpha and ∂loss_alpha unchanged: their log π comes from before the actor step). The actor, the "
        "critic and α are all updated on every update call (no delayed actor; update_every_steps=2 gates the whole "
        "update and is met at this step).",
        "DMC-GB2's metric alpha_value is read after its temperature step: equal at unchanged parameters, 'steps "
        "taken' differs by the one Adam step on log α (about lr = 1e-4).",
        "DMC-GB2's actor loss is backpropagated through the critic (not frozen) and leaves gradients in the critic's "
        ".grad, which actor_opt does not step and the next critic update zeroes first; vigen freezes the critic. No effect on "
        "any step (no stray gradient row).",
        "Strong view: DMC-GB2's compose_augs(['all']) (per sample one of conv, overlay, conv+overlay, rotate, shift, "
        "rotate+shift; overlay images from Places365 on CUDA, rotation by torchvision) is replaced by one draw of "
        "vigen's dmcgb2_strong_augmentation('all') (built-in image bank), replayed to both sides; the kernels are "
        f"checked against DMC-GB2's definitions in vigen's transform tests, not here. This batch's draw: {', '.join(drawn)}.",
        "nstep = 1 and discount γ as in DMC-GB2's config; the next observation is encoded by the online encoder "
        "without gradient on both sides (no target encoder).",
    ]
    return Case("sada", agent, loss, modules, steps, {"aug": views.weak(), "apply_strong_aug": strong_pairs}, [],
                [ref.modules["utils"]], metrics, departures, ref, batch, setup)
