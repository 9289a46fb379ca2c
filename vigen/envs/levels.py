"""Named generalization levels: which vigen transforms, with which exact parameters, each level applies.

The registry is data: :data:`LEVELS` maps a level name to a list of ``(transform, parameters)``
pairs (transform names from :mod:`vigen.transforms`), and :data:`GROUPS` names lists of levels.
``docs/levels.md`` is generated from it (``python -m vigen.envs.levels > docs/levels.md``) and a
test keeps the two equal.
"""

from __future__ import annotations

from typing import Any

from torchrl.envs import Transform

import vigen.transforms as transforms
from vigen.envs.pixels import derive_seed
from vigen.transforms.corruptions import SEVERITIES

CORRUPTION_SOURCE = "ImageNet-C severities (Hendrycks & Dietterich 2019)"

# name -> (what it shows, where it comes from, [(transform, parameters), ...])
LEVELS: dict[str, tuple[str, str, list[tuple[str, dict[str, Any]]]]] = {
    "train": ("the clean training scene", "all", []),
    "color_easy": (
        "floor, sky and agent colours: default + N(0, 0.1²) per channel",
        "DMC-GB color_easy (statistics of its presets)",
        [("RandomSceneColors", {"scale": 0.1})],
    ),
    "color_hard": (
        "floor, sky and agent colours: default + N(0, 0.2²) per channel",
        "DMC-GB color_hard (statistics of its presets)",
        [("RandomSceneColors", {"scale": 0.2})],
    ),
    "objects_color_easy": (
        "agent colour only: default + N(0, 0.1²)",
        "RL-ViGen objects_color easy",
        [("RandomSceneColors", {"scale": 0.1, "parts": ("self",)})],
    ),
    "objects_color_hard": (
        "agent colour only: default + N(0, 0.2²)",
        "RL-ViGen objects_color hard",
        [("RandomSceneColors", {"scale": 0.2, "parts": ("self",)})],
    ),
    "floor_texture": (
        "floor grid replaced by a texture image",
        "RL-ViGen table_texture (labmaze and procedural textures)",
        [("RandomTextures", {})],
    ),
    "video_easy": (
        "sky replaced by a video, new frame every step",
        "DMC-GB video_easy (procedural videos unless a folder is given)",
        [("VideoBackground", {"floor": False})],
    ),
    "video_hard": (
        "sky and floor replaced by a video, new frame every step",
        "DMC-GB video_hard (procedural videos unless a folder is given)",
        [("VideoBackground", {"floor": True})],
    ),
    "light_easy": (
        "light position +{3, 4}, diffuse ± 0.2, light moving 0.01/step within ± 5",
        "RL-ViGen light_position + light_color + moving_light, easy",
        [("RandomLighting", dict(transforms.RandomLighting.LEVELS["easy"]))],
    ),
    "light_hard": (
        "light position +{9, 10}, diffuse ± 10, light moving 0.05/step within ± 10",
        "RL-ViGen light_position + light_color + moving_light, hard",
        [("RandomLighting", dict(transforms.RandomLighting.LEVELS["hard"]))],
    ),
    "camera_easy": (
        "camera moved ± 0.08, turned ± 9°, field of view −4° … +5°",
        "RL-ViGen cam_pos easy; DCS camera scale 0.1; RL-ViGen Adroit FOV easy",
        [("RandomCamera", {"position": 0.08, "rotation_deg": 9.0, "fov_deg": (-4.0, 5.0)})],
    ),
    "camera_hard": (
        "camera moved ± 0.15, turned ± 27°, field of view ± 10°",
        "RL-ViGen cam_pos hard; DCS camera scale 0.3; RL-ViGen Adroit FOV hard",
        [("RandomCamera", {"position": 0.15, "rotation_deg": 27.0, "fov_deg": (-10.0, 10.0)})],
    ),
    **{
        f"{corruption}_{severity}": (
            f"{corruption.replace('_', ' ')}, severity {severity} of 5",
            CORRUPTION_SOURCE,
            [("PixelCorruption", {"corruption": corruption, "severity": severity})],
        )
        for corruption in SEVERITIES
        for severity in range(1, 6)
    },
}

GROUPS: dict[str, list[str]] = {
    "dmcgb": ["color_easy", "color_hard", "video_easy", "video_hard"],
    "rlvigen": [
        "color_easy", "color_hard", "objects_color_easy", "objects_color_hard", "floor_texture",
        "video_easy", "video_hard", "light_easy", "light_hard", "camera_easy", "camera_hard",
    ],
    "corruptions": [f"{c}_{s}" for c in SEVERITIES for s in range(1, 6)],
    "all": list(LEVELS),
}


def suite_levels(suite: str = "dmc") -> tuple[dict[str, Any], dict[str, list[str]]]:
    """The level and group tables of a suite: this module's for ``dmc``, the suite module's ``LEVELS``/``GROUPS`` otherwise.

    Examples:
        >>> from vigen.envs.levels import suite_levels
        >>> levels, groups = suite_levels("robosuite")
        >>> groups["rlvigen"]
        ['easy', 'medium', 'hard']
    """
    if suite == "dmc":
        return LEVELS, GROUPS
    from vigen.envs.registry import suite_module

    module = suite_module(suite)
    return module.LEVELS, module.GROUPS


def resolve_levels(names: str | list[str], suite: str = "dmc") -> list[str]:
    """Expand group names (``dmcgb``, ``rlvigen``, ``corruptions``, ``all`` for ``dmc``) into level names, in order.

    Examples:
        >>> from vigen.envs.levels import resolve_levels
        >>> resolve_levels(["train", "dmcgb"])
        ['train', 'color_easy', 'color_hard', 'video_easy', 'video_hard']
    """
    levels, groups = suite_levels(suite)
    names = [names] if isinstance(names, str) else list(names)
    resolved: list[str] = []
    for name in names:
        if name in groups:
            resolved += groups[name]
        elif name in levels:
            resolved.append(name)
        else:
            raise ValueError(
                f"Unknown generalization level {name!r} for {suite}/ envs. Levels: {', '.join(levels)}. "
                f"Groups: {', '.join(groups)}."
            )
    return list(dict.fromkeys(resolved))


def level_transforms(level: str, seed: int | None = None, **overrides: Any) -> list[Transform]:
    """The transforms of ``level``, the ``i``-th seeded with :func:`~vigen.envs.pixels.derive_seed` ``(seed, i)``.

    ``overrides`` are passed to every transform of the level that accepts them, e.g.
    ``videos="/data/dmcgb/video_hard"`` or ``palette=".../color_hard.pt"``.
    """
    if level not in LEVELS:
        resolve_levels(level)  # raises the error that lists the names
        raise ValueError(f"{level!r} is a group of levels, not one level: {GROUPS[level]}.")
    built = []
    for index, (name, parameters) in enumerate(LEVELS[level][2]):
        cls = getattr(transforms, name)
        accepted = {k: v for k, v in overrides.items() if k in cls.__init__.__code__.co_varnames}
        built.append(cls(**parameters, **accepted, seed=derive_seed(seed, index)))
    return built


def levels_markdown() -> str:
    """The table of every level and its exact parameters (the content of ``docs/levels.md``)."""

    def show(value: Any) -> str:
        return repr(value).replace("|", "\\|")

    lines = [
        "# Generalization levels",
        "",
        "Generated from `vigen/envs/levels.py` by `python -m vigen.envs.levels > docs/levels.md`; a test keeps them equal.",
        "Use a level with `make_env(name, generalization=level, seed=...)`.",
        "",
        "| level | what changes | transforms and exact parameters | source |",
        "|---|---|---|---|",
    ]
    for level, (what, source, steps) in LEVELS.items():
        spec = "; ".join(f"`{name}({', '.join(f'{k}={show(v)}' for k, v in params.items())})`" for name, params in steps)
        lines.append(f"| `{level}` | {what} | {spec or '—'} | {source} |")
    lines += ["", "| group | levels |", "|---|---|"]
    lines += [f"| `{group}` | {', '.join(f'`{name}`' for name in names)} |" for group, names in GROUPS.items()]
    lines += _suite_markdown("robosuite", "robosuite/door", "the transforms for `robosuite/door`, scene 0")
    lines += _suite_markdown("adroit", "adroit/door", "the transforms")
    return "\n".join(lines) + "\n"


def _suite_markdown(suite: str, example: str, shown: str) -> list[str]:
    """The level table of another suite: what each level shows, its source, and the transforms (with their parameters)."""
    from vigen.envs.registry import suite_module

    module = suite_module(suite)
    task = example.split("/", 1)[1]
    lines = ["", f"## {suite}/ levels", "", f"Use a level with `make_env(\"{example}\", generalization=level, seed=...)`; "
             f"the last column lists {shown}.", "", "| level | what changes | source | transforms |", "|---|---|---|---|"]
    for level, (what, source) in module.LEVELS.items():
        built = module.level_transforms(task, level) if suite == "robosuite" else module.level_transforms(level)
        spec = "; ".join(f"`{transform!r}`".replace("|", "\\|") for transform in built)
        lines.append(f"| `{level}` | {what} | {source} | {spec or '—'} |")
    lines += ["", "| group | levels |", "|---|---|"]
    lines += [f"| `{group}` | {', '.join(f'`{name}`' for name in names)} |" for group, names in module.GROUPS.items()]
    return lines


if __name__ == "__main__":
    print(levels_markdown(), end="")


def make_perturbations(
    generalization: str | list[Transform] | None, seed: int | None = None, **options: Any
) -> list[Transform]:
    """The transforms for ``make_env(..., generalization=...)``: a level name, a list of transforms, or ``None``."""
    from vigen.envs.pixels import perturbations

    return perturbations(generalization, lambda level: level_transforms(level, seed, **options))
