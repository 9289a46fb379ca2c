"""The Suite record: everything vigen knows about one simulator, and the one path from a name and a level to an env.

``make_env(name, generalization=..., seed=...)`` reads top-down:

1. :func:`~vigen.envs.registry.make_env` finds the :class:`Suite` of ``name``'s prefix;
2. :meth:`Suite.make` checks every argument, then looks the level up in the suite's table (a
   named :class:`~vigen.envs.level_types.Level`, a dict of :class:`~vigen.envs.level_types.Factor`
   intensities, or the user's transforms);
3. :meth:`Suite.build_level` turns the level's steps into transforms (parameters evaluated for the
   task and scene, ``level_options`` on top);
4. the suite's builder makes the raw-frame base env (simulators are imported there, lazily);
5. :func:`~vigen.envs.pixels.stacked_pixel_env` puts the transforms, channel-first frames and
   the frame stack around it, and seeds every transform with :func:`~vigen.envs.pixels.derive_seed`.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from torchrl.envs import EnvBase, Transform

from vigen.envs.factors import FACTORS
from vigen.envs.level_types import Factor, Level, LevelContext, Step, check_intensity, evaluate_value, level_label
from vigen.envs.pixels import PixelEnv, check_env_arguments, check_scene_id, check_transforms, seed_in_order, stacked_pixel_env


@dataclass
class BuiltLevel:
    """A level's transforms as built for one env, with the steps and contexts they came from.

    :meth:`select_scene` moves the level to another scene by re-evaluating the parameters that
    follow the scene id (robosuite's texture set and video), without rebuilding anything.
    """

    label: str
    parts: list[tuple[Step, LevelContext, Transform]] = field(default_factory=list)

    @property
    def transforms(self) -> list[Transform]:
        return [transform for _, _, transform in self.parts]

    @property
    def data_sources(self) -> list[tuple[str, bool]]:
        """(what it shows, whether it is a stand-in) for each of the level's transforms that shows data (videos, presets, textures)."""
        return [(transform.data_source, bool(transform.uses_stand_in)) for transform in self.transforms
                if hasattr(transform, "data_source")]

    @property
    def data_source(self) -> str:
        """What the level shows, in a few words per transform (``"; "``-joined); ``""`` for a level that shows no data.

        Evaluation rows carry it (``data``), so a table says whether a number came from the
        benchmark's own data or from vigen's stand-ins.
        """
        return "; ".join(label for label, _ in self.data_sources)

    @property
    def uses_stand_in(self) -> bool:
        """True when any transform shows vigen's stand-ins where the level's source shows its own data."""
        return any(stand_in for _, stand_in in self.data_sources)

    def episode_data(self) -> dict[str, Any]:
        """What the current episode shows of the level's data (a video's file, a preset's index), merged over its transforms."""
        shown: dict[str, Any] = {}
        for transform in self.transforms:
            shown.update(transform.episode_data() if hasattr(transform, "episode_data") else {})
        return shown

    def select_scene(self, scene_id: int) -> None:
        """Show scene ``scene_id`` from the next reset on."""
        for step, context, transform in self.parts:
            for name, value in step.scene_params(dataclasses.replace(context, scene_id=scene_id)).items():
                setattr(transform, name, value)


@dataclass(frozen=True)
class Suite:
    """One simulator's tasks, builder, level table, groups, factors and defaults.

    Args:
        name: the env-name prefix, e.g. ``"dmc"``.
        about: one line for error messages and the docs.
        tasks: returns the task names (the part after ``"<name>/"``); may import the simulator.
        build_base: ``(task, *, seed, **env_options) -> env`` with uint8 HWC ``"pixels"`` and a ``scene`` property (the
            :class:`~vigen.transforms.scene.SceneHandle` scene transforms edit); it may import the simulator.
        levels: level name -> :class:`~vigen.envs.level_types.Level` (``"train"`` first).
        groups: group name -> level names.
        factors: factor name (from :data:`~vigen.envs.factors.FACTORS`) -> :class:`~vigen.envs.level_types.Factor`.
        example_task: a task for examples and the docs.
        env_options: the options ``build_base`` takes, with their defaults (for the docs and the checks).
        extra_transforms: transforms appended after the frame stack (dm_control: ``DoubleToFloat``).
        scenes: how many scenes a level can show (robosuite: RL-ViGen's 10); ``seed % scenes`` by default.
        install: how to install the simulator, for the error when it is missing.

    Examples:
        >>> from vigen.envs.registry import SUITES
        >>> dmc = SUITES["dmc"]
        >>> dmc.resolve_levels(["train", "dmcgb"])
        ['train', 'color_easy', 'color_hard', 'video_easy', 'video_hard']
        >>> "camera_rotation" in dmc.factors
        True
    """

    name: str
    about: str
    tasks: Callable[[], Sequence[str]]
    build_base: Callable[..., EnvBase]
    levels: Mapping[str, Level]
    groups: Mapping[str, Sequence[str]]
    factors: Mapping[str, Factor]
    example_task: str
    env_options: Mapping[str, Any] = field(default_factory=dict)
    extra_transforms: Callable[[], Sequence[Transform]] = tuple
    scenes: int = 1
    install: str = ""

    def __post_init__(self) -> None:
        unknown = set(self.factors) - set(FACTORS)
        if unknown:
            raise ValueError(f"Suite {self.name!r} declares factors outside the shared vocabulary: {sorted(unknown)}.")
        for group, names in self.groups.items():
            missing = [name for name in names if name not in self.levels]
            if missing:
                raise ValueError(f"Suite {self.name!r}: group {group!r} lists unknown levels {missing}.")

    # -- names -----------------------------------------------------------------------------------
    def env_names(self) -> list[str]:
        """Every ``"<suite>/<task>"`` name this suite builds."""
        return [f"{self.name}/{task}" for task in self.tasks()]

    def check_task(self, task: str) -> None:
        """Raise a clear error for an unknown task, with the closest valid names."""
        valid = list(self.tasks())
        if task not in valid:
            names = [f"{self.name}/{t}" for t in valid]
            close = difflib.get_close_matches(f"{self.name}/{task}", names, n=3, cutoff=0.6)
            hint = f" Did you mean {' or '.join(close)}?" if close else ""
            raise ValueError(f"Unknown env {f'{self.name}/{task}'!r}.{hint} Valid names: {', '.join(names)}.")

    def levels_for(self, task: str) -> list[str]:
        """The names of the levels that apply to ``task`` (all of them, except levels limited to other tasks)."""
        return [name for name, level in self.levels.items() if level.applies_to(task)]

    def resolve_levels(self, names: str | Sequence[str]) -> list[str]:
        """Expand group names into level names, in order, without repeats; unknown names raise listing the valid ones."""
        names = [names] if isinstance(names, str) else list(names)
        resolved: list[str] = []
        for name in names:
            if name in self.groups:
                resolved += self.groups[name]
            elif name in self.levels:
                resolved.append(name)
            else:
                close = difflib.get_close_matches(str(name), [*self.levels, *self.groups], n=3, cutoff=0.6)
                hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
                raise ValueError(
                    f"Unknown generalization level {name!r} for {self.name}/ envs.{hint} Levels: {', '.join(self.levels)}. "
                    f"Groups: {', '.join(self.groups)}. Factors (as a dict, e.g. {{'camera_rotation': 0.3}}): "
                    f"{', '.join(self.factors)}."
                )
        return list(dict.fromkeys(resolved))

    # -- levels ----------------------------------------------------------------------------------
    def level_option_names(self) -> set[str]:
        """Every ``level_options`` key some transform of this suite's levels or factors accepts."""
        steps = [step for level in self.levels.values() for step in level.steps]
        steps += [step for factor in self.factors.values() for step in factor.steps]
        return set().union(*(step.accepts() for step in steps))

    def check_level_options(self, options: Mapping[str, Any] | None) -> dict[str, Any]:
        """``options`` as a dict, or an error naming each key no transform of this suite accepts, with the valid ones."""
        if options is None:
            return {}
        if not isinstance(options, Mapping):
            raise TypeError(f"level_options must be a dict of transform arguments, got {type(options).__name__}.")
        valid = self.level_option_names()
        unknown = [key for key in options if key not in valid]
        if unknown:
            hints = [f"{key!r} (did you mean {difflib.get_close_matches(str(key), valid, n=1)[0]!r}?)"
                     if difflib.get_close_matches(str(key), valid, n=1) else repr(key) for key in unknown]
            raise ValueError(
                f"Unknown level_options for {self.name}/ envs: {', '.join(hints)}. No transform of the suite's levels "
                f"takes them. Valid keys: {', '.join(sorted(valid))}."
            )
        return dict(options)

    def options_taken(self, generalization: str | Mapping[str, float], task: str) -> set[str]:
        """The ``level_options`` keys the transforms of one level (a name or a factor dict) take at ``task``."""
        steps, _ = self.level_steps(generalization, task)
        return set().union(*(step.accepts() for step, _ in steps))

    def check_options_taken(self, generalization: str | Mapping[str, float] | Sequence[Transform] | Transform | None,
                            task: str, options: Mapping[str, Any]) -> None:
        """Raise, naming them, on ``options`` that no transform of this one level takes (they would do nothing)."""
        if not options:
            return
        if generalization is not None and not isinstance(generalization, (str, Mapping)):
            raise ValueError(f"level_options {sorted(options)} go to the transforms of vigen's named levels and factors; "
                             "with your own transforms, give those arguments to the transforms themselves.")
        steps, _ = self.level_steps(generalization or "train", task)
        taken = set().union(*(step.accepts() for step, _ in steps))
        unused = sorted(key for key in options if key not in taken)
        if unused:
            label = level_label(generalization or "train")
            names = ", ".join(sorted({step.transform.__name__ for step, _ in steps})) or "none"
            users = [name for name, level in self.levels.items()
                     if level.applies_to(task) and set(unused) & self.options_taken(name, task)]
            where = f" They apply at: {', '.join(users)}." if users else ""
            raise ValueError(
                f"level_options {', '.join(map(repr, unused))} do nothing at level {label!r} of {self.name}/ envs: its "
                f"transforms ({names}) take {', '.join(sorted(taken)) or 'no options'}.{where} Drop them for this level "
                "(vigen.evaluation.evaluate passes each level only the options its transforms take)."
            )

    def level_steps(self, generalization: str | Mapping[str, float], task: str) -> tuple[list[tuple[Step, LevelContext]], dict[str, Any]]:
        """The steps of a level name or a factor dict, each with its context, and the env options the level sets."""
        if isinstance(generalization, str):
            if generalization not in self.levels:
                resolved = self.resolve_levels(generalization)  # raises for unknown names
                raise ValueError(f"{generalization!r} is a group of levels, not one level: {resolved}.")
            level = self.levels[generalization]
            if not level.applies_to(task):
                raise ValueError(f"Level {generalization!r} applies to {', '.join(f'{self.name}/{t}' for t in level.tasks)} only, "
                                 f"not {self.name}/{task}.")
            return [(step, LevelContext(task)) for step in level.steps], dict(level.env_options)
        if not generalization:
            return [], {}
        unknown = [name for name in generalization if name not in self.factors]
        if unknown:
            elsewhere = [name for name in unknown if name in FACTORS]
            note = f" ({', '.join(elsewhere)} exist in other suites.)" if elsewhere else ""
            raise ValueError(f"Unknown factors {unknown} for {self.name}/ envs.{note} Factors: {', '.join(self.factors)}.")
        steps: list[tuple[Step, LevelContext]] = []
        env_options: dict[str, Any] = {}
        for name, intensity in generalization.items():
            x = check_intensity(name, intensity)
            if x == 0.0:
                continue
            context = LevelContext(task, intensity=x)
            factor = self.factors[name]
            steps += [(step, context) for step in factor.steps]
            env_options.update({key: evaluate_value(value, context) for key, value in factor.env_options.items()})
        return steps, env_options

    def build_level(
        self,
        generalization: str | Mapping[str, float] | Sequence[Transform] | Transform | None,
        task: str,
        scene_id: int = 0,
        options: Mapping[str, Any] | None = None,
    ) -> tuple[BuiltLevel | None, list[Transform], dict[str, Any]]:
        """The transforms of ``generalization`` for ``task`` at ``scene_id`` (unseeded), the level record, and its env options.

        User transforms (a list) come back as given (``Compose`` flattened), with no level record.
        """
        if generalization is None or isinstance(generalization, (str, Mapping)):
            steps, env_options = self.level_steps(generalization or "train", task)
            built = BuiltLevel(level_label(generalization))
            for step, context in steps:
                context = dataclasses.replace(context, scene_id=scene_id)
                built.parts.append((step, context, step.build(context, options)))
            return built, built.transforms, env_options
        return None, check_transforms(generalization), {}

    def level_transforms(self, task: str, level: str | Mapping[str, float], scene_id: int = 0, seed: int | None = None,
                         **options: Any) -> list[Transform]:
        """The transforms of ``level`` for ``task`` and scene ``scene_id``, the ``i``-th seeded with ``derive_seed(seed, i)``."""
        self.check_task(task)
        _, transforms, _ = self.build_level(level, task, scene_id, self.check_level_options(options))
        return seed_in_order(transforms, seed)

    # -- envs ------------------------------------------------------------------------------------
    def check_env_options(self, env_options: Mapping[str, Any]) -> None:
        """Unknown options raise, listing the builder's; known ones get :func:`check_env_arguments`' checks."""
        unknown = [name for name in env_options if name not in self.env_options]
        if unknown:
            raise TypeError(
                f"{self.name}/ envs take no option {', '.join(map(repr, unknown))}. Options: frame_stack, generalization, "
                f"seed, level_options, {'scene_id, ' if self.scenes > 1 else ''}{', '.join(self.env_options)}."
            )
        check_env_arguments(**{name: value for name, value in env_options.items() if name in CHECKED_OPTIONS})

    def make(
        self,
        task: str,
        *,
        frame_stack: int = 3,
        generalization: str | Mapping[str, float] | Sequence[Transform] | None = None,
        seed: int | None = None,
        scene_id: int | None = None,
        level_options: Mapping[str, Any] | None = None,
        **env_options: Any,
    ) -> PixelEnv:
        """Build ``"<suite>/<task>"`` at a level: the one path every vigen env takes (see the module docstring)."""
        self.check_task(task)
        check_env_arguments(frame_stack=frame_stack, seed=seed)
        self.check_env_options(env_options)
        if scene_id is not None:
            if self.scenes == 1 and scene_id != 0:
                raise ValueError(f"{self.name}/ levels have one scene; scene_id must be None or 0, got {scene_id!r}.")
            check_scene_id(scene_id, self.scenes)
        options = self.check_level_options(level_options)
        self.check_options_taken(generalization, task, options)
        scene = (0 if seed is None else seed % self.scenes) if scene_id is None else int(scene_id)
        level, transforms, level_env_options = self.build_level(generalization, task, scene, options)
        for name, value in level_env_options.items():
            if name in env_options and env_options[name] != value:
                raise ValueError(f"Level {level_label(generalization)!r} sets {name}={value!r}, but {name}={env_options[name]!r} was given.")
        base = self.build_base(task, seed=seed, **{**level_env_options, **env_options})
        return stacked_pixel_env(base, transforms, frame_stack, *self.extra_transforms(), seed=seed, level=level,
                                 scenes=self.scenes, scene_id=scene, scene_follows_seed=scene_id is None)


CHECKED_OPTIONS = ("action_repeat", "image_size", "camera_id", "camera", "episode_length", "control_freq")
"""Env options with a rule in :func:`~vigen.envs.pixels.check_env_arguments`."""
