"""Each method's original training settings as a named recipe: ``examples/train.py --recipe svea-dmcgb``.

A protocol (:mod:`vigen.protocols`) fixes the env: budget, action repeat, frame stack, evaluation.
A recipe fixes the method as its original code trains it: the loss (a vigen algorithm and its
options), the networks, the optimizer (per-module learning rates and Adam's betas) and the update
schedule (batch, seed steps, which parts are stepped on which updates, the target networks' rates,
n-step, discount, buffer), read from the original's argument files and agent code, and the
protocol its numbers were published under. Where the original's code and its text disagree, the
code wins (:attr:`Recipe.notes` says so); where vigen still trains differently, the recipe names
the difference (:attr:`Recipe.departures`). ``docs/recipes.md`` holds every value with the
source's ``file:line``; a test reads each value against that table.

A recipe's settings are flat, one name each (:meth:`Recipe.settings`):

* :class:`~vigen.run.TrainConfig` fields (``batch_size``, ``lr``, ``tau``, ``seed_steps``,
  ``actor_update_every``, ...): a flag that changes one is recorded in ``config.json`` as a
  recipe override (``recipe_overrides``), as protocol overrides are;
* ``loss.<option>``: keyword arguments of :func:`vigen.losses.make_loss` (parts by name,
  ``loss.strong_augmentation`` by a name of :data:`AUGMENTATION_NAMES`);
* ``optimizer.betas`` (Adam's, for every group without its own) and ``optimizer.<module>.<option>``:
  the loss's ``param_groups`` (``lr``, ``betas``, ``every``);
* ``network.<property>``: what the built networks must be (their encoder's layers and channels),
  checked when the agent is built; ``network.weights``: the data set (``python -m vigen.datasets``)
  that holds the pretrained encoder the recipe loads.

This module imports neither torch nor the losses, so that a config can name a recipe anywhere.

Examples:
    >>> from vigen.run.recipes import RECIPES
    >>> svea = RECIPES["svea-dmcgb"]
    >>> svea.algo, svea.protocol, svea.settings("dmc/walker-walk")["batch_size"]
    ('svea', 'dmcgb', 128)
    >>> settings = svea.settings("dmc/walker-walk")
    >>> settings["optimizer.sampler.lr"], settings["optimizer.sampler.betas"], settings["actor_update_every"]
    (0.0001, (0.5, 0.999), 2)
    >>> RECIPES["drqv2"].settings("dmc/walker-walk")["batch_size"], RECIPES["drqv2"].settings("dmc/cheetah-run")["std_duration"]
    (512, 500000)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

AUGMENTATION_NAMES: Mapping[str, str] = MappingProxyType({
    "overlay": "RandomOverlay(alpha=0.5)",
    "random_conv": "RandomConv()",
    "shifted_overlay": "RandomShiftedOverlay(alpha=0.5, max_shift=6)",
    "srm": "RandomOverlay(alpha=0.5) then RandomFrequencyMask()",
    "dmcgb2_all": 'dmcgb2_strong_augmentation("all")',
})
"""The strong augmentations a recipe names (``loss.strong_augmentation``) → what :func:`vigen.run.build_agent` builds."""

TRAIN_KEYS = ("algo", "protocol", "batch_size", "buffer_size", "lr", "hidden_dim", "feature_dim", "n_step", "gamma", "tau",
              "encoder_tau", "seed_frames", "seed_steps", "seed_catch_up", "update_every", "actor_update_every",
              "target_update_every", "std_init", "std_final", "std_duration")
"""The :class:`~vigen.run.TrainConfig` fields a recipe may set (the rest of its settings are ``loss.``, ``optimizer.``,
``network.``)."""

GROUPS = ("loss.", "optimizer.", "network.")


@dataclass(frozen=True)
class Recipe:
    """One method as its original code trains it: vigen's algorithm, its settings, the protocol, what still differs.

    Args:
        name: ``<method>-<where it was published>``, the ``--recipe`` value.
        title: the method and the code read, for listings.
        code: the repository and commit (or branch) the settings were read from.
        algo: the vigen algorithm (:data:`vigen.losses.ALGOS`).
        protocol: the protocol its numbers were published under (:data:`vigen.protocols.PROTOCOLS`); per suite in
            ``protocol_by_suite`` where it differs.
        suites: the env suites the original's configs cover.
        common: the settings on every task, flat (see the module docstring); :meth:`settings` adds the task's.
        tasks: task → group (``"easy"``, ``"medium"``, ``"hard"``) where the original keeps one config per task (DrQ-v2,
            RL-ViGen): only these tasks are covered. ``None``: every task of the suites.
        group_settings: group → the settings its tasks take (DrQ-v2's exploration std per difficulty).
        task_settings: ``<domain>`` or ``<domain>-<task>`` → the settings its config changes (a task's win over its domain's).
        departures: name → how vigen still trains differently from the original, in words.
        notes: setting → where the original's code and its text (or its launch commands) disagree, and which is taken.
    """

    name: str
    title: str
    code: str
    algo: str
    protocol: str | None
    suites: tuple[str, ...]
    common: Mapping[str, Any]
    tasks: Mapping[str, str] | None = None
    group_settings: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    task_settings: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    protocol_by_suite: Mapping[str, str] = field(default_factory=dict)
    departures: Mapping[str, str] = field(default_factory=dict)
    notes: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("common", "group_settings", "task_settings", "protocol_by_suite", "departures", "notes"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        if self.tasks is not None:
            object.__setattr__(self, "tasks", MappingProxyType(dict(self.tasks)))
        for where, values in [("common", self.common), *self.group_settings.items(), *self.task_settings.items()]:
            unknown = [key for key in values if key not in TRAIN_KEYS and not key.startswith(GROUPS)]
            if unknown:
                raise ValueError(f"recipe {self.name}: {where} holds {unknown}, which are neither TrainConfig fields "
                                 f"({', '.join(TRAIN_KEYS)}) nor loss./optimizer./network. settings.")

    def protocol_for(self, env: str) -> str | None:
        """The protocol the recipe's numbers on ``env``'s suite were published under."""
        return self.protocol_by_suite.get(env.split("/", 1)[0], self.protocol)

    def settings(self, env: str) -> dict[str, Any]:
        """Every setting of the recipe on ``env``, flat: its own, its task group's, its domain's, its task's.

        Raises:
            ValueError: ``env`` is on a suite, or a task, the original has no config for (the message lists them).
        """
        suite, _, task = env.partition("/")
        if suite not in self.suites:
            raise ValueError(f"recipe {self.name} covers the {', '.join(self.suites)} suite(s), not {suite!r} ({env}).")
        if self.tasks is not None and task not in self.tasks:
            listed = ", ".join(sorted(name for name in self.tasks if name.split("/")[0] == suite or "/" not in name))
            raise ValueError(f"recipe {self.name}: {self.code} has no config for {env}; its {suite} tasks are {listed}.")
        values = {"algo": self.algo, "protocol": self.protocol_for(env), **self.common}
        if self.tasks is not None:
            values.update(self.group_settings.get(self.tasks[task], {}))
        values.update(self.task_settings.get(task.split("-", 1)[0], {}))
        values.update(self.task_settings.get(task, {}))
        return values

    def rows(self) -> list[tuple[str, Any]]:
        """Every setting as ``docs/recipes.md`` lists it: ``(setting, value)``, ``[group]`` / ``[task]`` after per-task ones.

        Examples:
            >>> from vigen.run.recipes import RECIPES
            >>> ("batch_size [walker]", 512) in RECIPES["drqv2"].rows()
            True
        """
        rows = [("algo", self.algo), ("protocol", self.protocol), *self.common.items()]
        rows += [(f"protocol [{suite}]", name) for suite, name in self.protocol_by_suite.items()]
        if self.tasks is not None:
            for group in dict.fromkeys(self.tasks.values()):
                rows.append((f"tasks [{group}]", ", ".join(task for task, of in self.tasks.items() if of == group)))
        rows += [(f"{key} [{group}]", value) for group, values in self.group_settings.items() for key, value in values.items()]
        rows += [(f"{key} [{task}]", value) for task, values in self.task_settings.items() for key, value in values.items()]
        return rows

    def describe(self, env: str | None = None) -> list[str]:
        """The recipe as lines a run (``--recipe list``, a run's start) prints."""
        protocols = ", ".join([str(self.protocol), *(f"{name} on {suite}" for suite, name in self.protocol_by_suite.items())])
        lines = [f"recipe {self.name}: {self.title}", f"  code: {self.code}",
                 f"  vigen algorithm {self.algo}; published under protocol {protocols}; suites {', '.join(self.suites)}"]
        values = self.settings(env) if env is not None else {"algo": self.algo, **self.common}
        shown = [f"{key} {value}" for key, value in values.items() if key not in ("algo", "protocol")]
        lines.append("  settings: " + "; ".join(shown))
        if env is None and (self.group_settings or self.task_settings):
            per_task = [f"{key} {value} [{where}]" for where, items in (*self.group_settings.items(),
                                                                             *self.task_settings.items())
                        for key, value in items.items()]
            lines.append("  per task: " + "; ".join(per_task))
        lines += [f"  departs ({name}): {text}" for name, text in self.departures.items()]
        lines += [f"  note ({name}): {text}" for name, text in self.notes.items()]
        return lines


def differences(run: Mapping[str, Any], published: Mapping[str, Any], *, run_name: str = "the run",
                published_name: str = "the published recipe") -> list[str]:
    """How two recipes' settings differ, one sentence per setting (``setting: A in <run>, B in <published>``).

    A setting only one side names is shown as ``not set`` on the other (vigen's default there).

    Examples:
        >>> differences({"batch_size": 256, "lr": 1e-4}, {"batch_size": 128, "lr": 1e-4, "seed_steps": 1000},
        ...             run_name="svea-rlvigen", published_name="svea-dmcgb")
        ['batch_size: 256 in svea-rlvigen, 128 in svea-dmcgb', 'seed_steps: not set in svea-rlvigen, 1000 in svea-dmcgb']
    """
    lines = []
    for key in dict.fromkeys([*run, *published]):
        mine, theirs = run.get(key, _UNSET), published.get(key, _UNSET)
        if _plain(mine) != _plain(theirs):
            lines.append(f"{key}: {_shown(mine)} in {run_name}, {_shown(theirs)} in {published_name}")
    return lines


_UNSET = object()


def _shown(value: Any) -> str:
    return "not set" if value is _UNSET else str(value)


def _plain(value: Any) -> Any:
    """Lists and tuples alike (JSON reads tuples back as lists)."""
    return tuple(_plain(item) for item in value) if isinstance(value, (list, tuple)) else value


def get_recipe(name: str) -> Recipe:
    """The recipe of a name, or a ``ValueError`` listing the names.

    Examples:
        >>> get_recipe("svea-dmcgb").algo
        'svea'
    """
    if name not in RECIPES:
        raise ValueError(f"--recipe {name}: no such recipe; choose one of {', '.join(RECIPES)} (--recipe list shows them).")
    return RECIPES[name]


def list_recipes() -> str:
    """Every recipe as ``examples/train.py --recipe list`` prints it.

    Examples:
        >>> print(list_recipes().splitlines()[0])
        recipe drqv2: DrQ-v2 as its authors train it (DDPG, n-step 3)
    """
    return "\n\n".join("\n".join(recipe.describe()) for recipe in RECIPES.values())


# -- the recipes -------------------------------------------------------------------------------------------------------

DRQV2_TASKS = {
    **dict.fromkeys(("cartpole-balance", "cartpole-balance_sparse", "cartpole-swingup", "ball_in_cup-catch", "cup-catch",
                     "finger-spin", "hopper-stand", "pendulum-swingup", "walker-stand", "walker-walk"), "easy"),
    **dict.fromkeys(("acrobot-swingup", "cartpole-swingup_sparse", "cheetah-run", "finger-turn_easy", "finger-turn_hard",
                     "hopper-hop", "quadruped-run", "quadruped-walk", "reacher-easy", "reacher-hard", "walker-run"), "medium"),
    **dict.fromkeys(("humanoid-stand", "humanoid-walk", "humanoid-run"), "hard"),
}
"""DrQ-v2's task configs (``cfgs/task/<task>.yaml``, vigen's names) and the difficulty each takes its defaults from."""

RLVIGEN_TASKS = {
    **DRQV2_TASKS,
    "door": "easy", "lift": "medium", "two-arm-peg-in-hole": "medium",
    "unitree-stand": "medium", "unitree-walk": "medium", "franka-reach": "medium",
}
"""RL-ViGen's task configs (``cfgs/task/*.yaml``) that name a vigen env: DrQ-v2's, robosuite's and the loco ones."""

DIFFICULTY_STD = {"easy": {"std_duration": 100_000}, "medium": {"std_duration": 500_000}, "hard": {"std_duration": 2_000_000}}
"""The exploration std's schedule length by difficulty (``linear(1.0, 0.1, N)`` of ``cfgs/task/{easy,medium,hard}.yaml``)."""

DRQV2_TASK_SETTINGS = {"walker": {"n_step": 1, "batch_size": 512},
                       "humanoid": {"lr": 8e-5, "feature_dim": 100},
                       "quadruped-run": {"buffer_size": 100_000}}
"""What DrQ-v2's (and RL-ViGen's) task configs change: walker's n-step and batch, humanoid's lr and trunk, quadruped-run's buffer."""

DRQV2_SETTINGS = {
    "batch_size": 256, "buffer_size": 1_000_000, "lr": 1e-4, "hidden_dim": 1024, "feature_dim": 50, "n_step": 3,
    "gamma": 0.99, "tau": 0.01, "seed_frames": 4000, "update_every": 2, "std_init": 1.0, "std_final": 0.1,
    "loss.clip": 0.3, "optimizer.betas": (0.9, 0.999),
}
"""DrQ-v2's ``cfgs/config.yaml`` (RL-ViGen's configs repeat it): what every DDPG recipe of the two starts from."""

ONE_STEP = ("the original steps the encoder and critic first and computes the actor loss on the stepped critic, each with "
            "its own Adam; vigen computes every term at the parameters of the batch's start and takes one step for all "
            "(benchmarks/parity measures the difference: docs/parity.md)")
DMCGB_ONE_STEP = ("DMC-GB's SAC steps the critic, then the actor and temperature on the stepped critic, each with its own "
                  "Adam; vigen computes every term at the parameters of the batch's start and steps once (the actor and "
                  "temperature groups every second update, as the original; docs/parity.md)")
DMCGB_CATCH_UP = ("the original makes its init_steps catch-up updates all with the same step (its train.py), so its actor, "
                  "temperature and targets are stepped in each of them, and then on its even env steps (updates 1, 3, 5, "
                  "... counted from 0); vigen steps them on updates 0, 2, 4, ... throughout: the same rate after the "
                  "catch-up, one update apart")
DMCGB_CONV_INIT = ("DMC-GB initialises the convolutions delta-orthogonally (only the kernel's centre, modules.py "
                   "weight_init); vigen's encoders use DrQ-v2's orthogonal initialisation of the whole kernel")
UINT8_OVERLAY = "vigen blends the overlay on uint8 frames and rounds back to uint8 (the original blends floats: half a grey level)"

DMCGB_SAC = {
    "batch_size": 128, "buffer_size": 500_000, "lr": 1e-3, "hidden_dim": 1024, "feature_dim": 100, "n_step": 1,
    "gamma": 0.99, "tau": 0.01, "encoder_tau": 0.05, "seed_steps": 1000, "seed_catch_up": True, "update_every": 1,
    "actor_update_every": 2, "target_update_every": 2,
    "loss.init_temperature": 0.1, "loss.log_std_bounds": (-10.0, 2.0), "loss.squash_epsilon": 1e-6,
    "loss.target_encoder": True, "loss.weak_weight": 0.5, "loss.strong_weight": 0.5,
    "optimizer.betas": (0.9, 0.999), "optimizer.actor.lr": 1e-3, "optimizer.actor.betas": (0.9, 0.999),
    "optimizer.sampler.lr": 1e-4, "optimizer.sampler.betas": (0.5, 0.999),
    "network.encoder_layers": 11, "network.encoder_channels": 32,
}
"""DMC-GB's SAC (``src/arguments.py``, ``src/algorithms/sac.py``, ``src/train.py``), which MaDi, SimGRL and SCPL fork."""


def _recipes() -> dict[str, Recipe]:
    rlvigen = "gemcollector/RL-ViGen@90d8b8c"
    ddpg = {"drqv2": {}, "svea": {}, "srm": {},
            "sgqn": {"loss.quantile": 0.93, "loss.consistency_weight": 0.9, "optimizer.decoder.lr": 1e-4,
                     "optimizer.decoder.betas": (0.99, 0.999)},
            "curl": {"optimizer.head.lr": 1e-4, "optimizer.head.betas": (0.99, 0.999)},
            "pieg": {"network.weights": "torchvision-resnet18"}}
    rlvigen_departures = {
        "drqv2": {"one-step": ONE_STEP},
        "svea": {"one-step": ONE_STEP, "uint8-overlay": UINT8_OVERLAY},
        "srm": {"one-step": ONE_STEP, "uint8-overlay": UINT8_OVERLAY,
                "srm-mask-clamp": "RL-ViGen's frequency-masked images are not clamped to [0, 255]; vigen's are"},
        "sgqn": {"one-step": ONE_STEP,
                 "sgqn-second-adam": "RL-ViGen recomputes the saliency mask after the critic step and steps the encoder a "
                                     "second time with the attribution head's Adam (lr 1e-4, betas 0.99, 0.999); vigen "
                                     "steps the encoder once, the head with its own betas"},
        "curl": {"one-step": ONE_STEP,
                 "curl-second-step": "RL-ViGen encodes the anchor after the critic step and steps the encoder a second time "
                                     "(encoder_opt with the head's Adam); vigen steps the encoder once"},
        "pieg": {"one-step": ONE_STEP,
                 "pieg-batchnorm-pass": "RL-ViGen's build-time forward pass moves the BatchNorm statistics one momentum "
                                        "step (the gap shrinks x0.9 per encoder pass)"},
    }
    recipes = [Recipe(
        name="drqv2", title="DrQ-v2 as its authors train it (DDPG, n-step 3)", code="facebookresearch/drqv2@c0c650b",
        algo="drqv2", protocol="drqv2", suites=("dmc",), common=DRQV2_SETTINGS, tasks=DRQV2_TASKS,
        group_settings=DIFFICULTY_STD, task_settings=DRQV2_TASK_SETTINGS,
        departures={"one-step": ONE_STEP},
        notes={"seed_frames": "num_expl_steps 2000 (random actions for the first 2000 agent steps) equals the 4000 seed "
                              "frames at DrQ-v2's action repeat 2; vigen acts randomly for the seed frames"})]
    for algo, extra in ddpg.items():
        recipes.append(Recipe(
            name=f"{algo}-rlvigen", title=f"{algo.upper() if algo != 'pieg' else 'PIE-G'} as RL-ViGen trains it "
                                          "(DrQ-v2's DDPG)",
            code=rlvigen, algo=algo, protocol="rlvigen", protocol_by_suite={"loco": "rlvigen_loco"},
            suites=("dmc", "robosuite", "loco"), common={**DRQV2_SETTINGS, **extra}, tasks=RLVIGEN_TASKS,
            group_settings=DIFFICULTY_STD, task_settings=DRQV2_TASK_SETTINGS, departures=rlvigen_departures[algo],
            notes={"suites": "its Adroit runs use the ViGen-adroit branch's cfgs_adroit, which this recipe does not cover",
                   **({"network.weights": "RL-ViGen builds torchvision's resnet18(pretrained=True), which torchvision "
                                          "downloads as resnet18-f37072fd.pth since its 2020 re-upload of the same weights "
                                          "(pytorch/vision#2068; before, resnet18-5c106cde.pth)"} if algo == "pieg" else {})}))
    recipes.append(Recipe(
        name="drq-rlvigen", title="DrQ as RL-ViGen trains it (SAC, a clean and a shifted view)", code=rlvigen,
        algo="drq", protocol="rlvigen", protocol_by_suite={"loco": "rlvigen_loco"}, suites=("dmc", "robosuite", "loco"),
        common={**{key: value for key, value in DRQV2_SETTINGS.items()
                     if key not in ("std_init", "std_final", "loss.clip")},
                  "n_step": 1, "loss.init_temperature": 0.1, "loss.log_std_bounds": (-10.0, 2.0),
                  "optimizer.sampler.lr": 1e-4},
        tasks=RLVIGEN_TASKS, task_settings=DRQV2_TASK_SETTINGS,
        departures={"one-step": ONE_STEP},
        notes={"std_duration": "its config passes a stddev_schedule the SAC agent never reads"}))
    recipes.append(Recipe(
        name="vrl3-rlvigen", title="VRL3's stage 3 as RL-ViGen's Adroit branch trains it (DDPG, safe Q)",
        code="gemcollector/RL-ViGen@ViGen-adroit (src/)", algo="vrl3", protocol="rlvigen", suites=("adroit",),
        common={"batch_size": 256, "buffer_size": 1_000_000, "lr": 1e-4, "hidden_dim": 1024, "feature_dim": 50,
                  "n_step": 3, "gamma": 0.99, "tau": 0.01, "seed_frames": 0, "update_every": 2, "std_init": 0.01,
                  "std_final": 0.01, "std_duration": 500_000, "loss.clip": 0.3, "loss.safe_q_threshold": 200.0,
                  "loss.safe_q_factor": 0.5, "loss.pretanh_threshold": 5.0, "loss.pretanh_weight": 0.001,
                  "optimizer.betas": (0.9, 0.999), "optimizer.encoder.lr_scale": 1.0},
        task_settings={"relocate": {"optimizer.encoder.lr_scale": 0.01}},
        departures={"one-step": ONE_STEP,
                    "no-stage-2": "RL-ViGen preloads 25 demonstrations and runs 30,000 offline updates (stage 2) before "
                                  "stage 3; vigen has no demonstrations and starts at stage 3",
                    "pixels-only": "RL-ViGen's Adroit agent also reads the robot's sensors (use_sensor: true); vigen's "
                                   "VRL3 sees pixels only",
                    "stage-1-weights": "RL-ViGen loads VRL3's ImageNet-pretrained stage-1 encoder; vigen cannot fetch it: "
                                       "pass --encoder-weights, or the encoder starts from random weights (and warns)"},
        notes={"reward_scale": "RL-ViGen rescales Adroit's rewards (reward_rescale: true); vigen's vrl3 algorithm applies "
                               "the same factors (door 1/20, hammer 1/100, pen 1/50) unless --reward-scale is given"}))
    recipes.append(Recipe(
        name="sada-dmcgb2", title="SADA as DMC-GB2 trains it (SAC, all six strong augmentations)",
        code="aalmuzairee/dmcgb2@5fd8fd7", algo="sada", protocol="dmcgb2", suites=("dmc",),
        common={"batch_size": 256, "buffer_size": 1_000_000, "lr": 5e-4, "hidden_dim": 1024, "feature_dim": 50,
                  "n_step": 1, "gamma": 0.99, "tau": 0.01, "seed_frames": 4000, "update_every": 2,
                  "loss.init_temperature": 0.1, "loss.log_std_bounds": (-10.0, 2.0),
                  "loss.strong_augmentation": "dmcgb2_all", "optimizer.betas": (0.9, 0.999), "optimizer.sampler.lr": 5e-4},
        departures={"one-step": "DMC-GB2 steps the encoder and critic, then the actor and temperature on the stepped "
                                "critic; vigen computes every term at the batch's start and steps once (docs/parity.md)"},
        notes={"seed_frames": "num_expl_steps 2000 (random actions for the first 2000 agent steps) equals the 4000 seed "
                              "frames at DMC-GB2's action repeat 2; vigen acts randomly for the seed frames"}))
    recipes.append(Recipe(
        name="svea-dmcgb", title="SVEA as DMC-GB trains it (SAC, random convolution, the published SVEA)",
        code="nicklashansen/dmcontrol-generalization-benchmark@ff9c0aa", algo="svea", protocol="dmcgb", suites=("dmc",),
        common={**DMCGB_SAC, "loss.encoder_type": "shared_cnn_01", "loss.actor_type": "gaussian_projected",
                  "loss.sampler_type": "squashed_gaussian", "loss.strong_augmentation": "random_conv",
                  "loss.augment_next": True},
        departures={"one-step": DMCGB_ONE_STEP, "catch-up-updates": DMCGB_CATCH_UP, "conv-init": DMCGB_CONV_INIT,
                    "not-parity-measured": "benchmarks/parity measures DMC-GB's SAC through MaDi's and SimGRL's forks, "
                                           "not DMC-GB's svea.py itself"}))
    recipes.append(Recipe(
        name="madi-dmcgb", title="MaDi as its authors train it (DMC-GB's SAC, a soft masker, overlay)",
        code="bramgrooten/mask-distractions@70982ce", algo="madi", protocol="dmcgb", suites=("dmc",),
        common={**DMCGB_SAC, "batch_size": 64, "loss.strong_augmentation": "overlay", "loss.augment_next": False,
                  "optimizer.input_mask.lr": 1e-3, "optimizer.input_mask.betas": (0.9, 0.999),
                  "network.masker_layers": 3, "network.masker_channels": 32},
        departures={"one-step": DMCGB_ONE_STEP, "conv-init": DMCGB_CONV_INIT, "uint8-overlay": UINT8_OVERLAY,
                    "phase": "MaDi numbers its catch-up updates 1 to init_steps and then its env steps, so its actor, "
                             "temperature and targets are stepped on updates 1, 3, 5, ... (counted from 0); vigen's on "
                             "0, 2, 4, ...: the same rate, one update apart"},
        notes={"batch_size": "arguments.py's default is 64; its help text (and the paper) say the CNN runs used 128: the "
                             "code's 64 is taken (--batch-size 128 for the paper's)",
               "loss.strong_augmentation": "arguments.py's default --augment is none; the README's command trains MaDi "
                                           "with --augment overlay, which the recipe takes",
               "action_repeat": "arguments.py's default action repeat is 4 on every task; protocol dmcgb's is 8 on "
                                "cartpole and 2 on finger (the recipe keeps the protocol's)",
               "network.masker_layers": "its masks are soft (mask_type soft, the default), the only kind vigen's masker "
                                        "makes"}))
    recipes.append(Recipe(
        name="simgrl-dmcgb", title="SimGRL as its authors train it (DMC-GB's SAC, per-frame encoder, shifted overlay)",
        code="W-Song11/SimGRL-Code@08722a8", algo="simgrl", protocol="dmcgb", suites=("dmc",),
        common={**{key: value for key, value in DMCGB_SAC.items() if not key.startswith("network.")},
                  "loss.strong_augmentation": "shifted_overlay", "loss.augment_next": True},
        departures={"one-step": DMCGB_ONE_STEP, "catch-up-updates": DMCGB_CATCH_UP, "conv-init": DMCGB_CONV_INIT,
                    "uint8-overlay": UINT8_OVERLAY}))
    recipes.append(Recipe(
        name="scpl-dmcgb", title="SCPL as its authors train it (DMC-GB's SAC, masked-Q consistency, policy KL, dynamics)",
        code="bofusun/SCPL@e77b623", algo="scpl", protocol="dmcgb", suites=("dmc",),
        common={**DMCGB_SAC, "buffer_size": 100_000, "loss.quantile": 0.9,
                  "optimizer.dynamics.lr": 3e-4, "optimizer.dynamics.betas": (0.9, 0.999), "optimizer.dynamics.every": 2},
        departures={"one-step": "SCPL steps the critic, then the actor and temperature, then (every second update) the "
                                "encoder and the dynamics model, each on the previous step's parameters; vigen computes "
                                "every term at the batch's start and steps once",
                    "scpl-encoder-adam": "SCPL steps the encoder a second time with the dynamics loss (its own Adam, lr "
                                         "3e-4, every second update); vigen's encoder takes the dynamics gradient in its "
                                         "one step, on every update",
                    "catch-up-updates": DMCGB_CATCH_UP, "conv-init": DMCGB_CONV_INIT},
        notes={"action_repeat": "my_train_all.py (the README's command) trains walker at action repeat 2 where protocol "
                                "dmcgb uses 4 (cartpole 8, finger 2, cheetah and ball_in_cup 4 agree); the recipe keeps "
                                "the protocol's",
               "buffer_size": "my_train_all.py's replay buffer holds 100,000 transitions (DMC-GB's: train_steps)"}))
    return {recipe.name: recipe for recipe in recipes}


RECIPES: Mapping[str, Recipe] = MappingProxyType(_recipes())
"""Recipe name → :class:`Recipe`; ``docs/recipes.md`` lists every setting with its source's ``file:line``."""
