"""The ``robosuite`` suite: manipulation tasks as pixel envs (RL-ViGen's setup), with RL-ViGen's levels as data.

RL-ViGen's levels (its ``eval-easy``/``medium``/``hard`` scene presets from SECANT, its camera
ranges and its cross-embodiment robots) are made of vigen's scene transforms, the same classes as
for dm_control, acting on the live model through :class:`~vigen.envs.robosuite.env.RobosuiteScene`.
A level shows one of 10 scenes (RL-ViGen's ``scene_id``): the texture draw and the ``hard`` video
follow the scene id (:class:`~vigen.envs.level_types.SceneIndex`). robosuite's own modders are not
used: on mujoco 3 they write to renamed texture fields, do not re-upload textures to an existing
render context, and save their defaults against a stale sim after a hard reset.

Examples:
    >>> from vigen.envs.robosuite.suite import ROBOSUITE
    >>> ROBOSUITE.groups["rlvigen"]
    ['easy', 'medium', 'hard']
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from vigen.envs.factors import CAMERA_FOV, CAMERA_ROTATION, DYNAMIC_COLOR, LIGHT_COLOR, NO_LIGHT_SHIFT, pixel_corruption_factors
from vigen.envs.level_types import ByTask, Choice, Factor, Level, Scaled, SceneIndex, Step
from vigen.envs.robosuite.env import ROBOTS, TASKS, RobosuitePixelEnv
from vigen.envs.suite import Suite
from vigen.transforms import (
    DistractingCamera,
    ImageBank,
    RandomCamera,
    RandomLighting,
    RandomMaterialColors,
    RandomTextures,
    VideoBackground,
)

ROBOT_PARTS = ("robot", "gripper", "fixed_mount")
"""Name prefixes of the robot's materials and geoms (arm, gripper, mount)."""

TEXTURES = {
    "door": ("texplane", "tex-light-gray-plaster", "tex-ceramic", "tex-steel-brushed", "Door_dark-wood", "Door_light-wood", "Door_metal"),
    "lift": ("texplane", "tex-light-gray-plaster", "tex-ceramic", "tex-steel-brushed", "cube_redwood"),
    "two-arm-peg-in-hole": ("texplane", "tex-light-gray-plaster", "hole_red-wood", "peg_greenwood"),
}
"""Textures the scene presets replace: floor, walls, table top and legs, and the task's objects (RL-ViGen's aliases)."""

BACKGROUND_TEXTURES = ("texplane", "tex-light-gray-plaster")
"""The floor and wall textures, which the ``hard`` level covers with a video instead."""

SCENES = 10
"""Scene presets per level (RL-ViGen's ``scene_id`` 0..9)."""

SCENE_LEVELS = ("easy", "medium", "hard")
"""The levels whose textures (and ``hard``'s video) depend on the scene id."""

ROBOSUITE_TEXTURES = {
    "easy": ("green-wood", "red-wood", "blue-wood", "gray-woodgrain", "gray-felt", "dirt"),
    "medium": ("wood-varnished-panels", "white-bricks"),
    "hard": (),
}
"""robosuite's own texture files in each level's texture set (RL-ViGen: WoodGreen ... Dirt; WoodPanels, BricksWhite)."""

GENERATED_TEXTURES = {"easy": 5, "medium": 20, "hard": 15}
"""Generated stand-ins for SECANT's Custom01–05, Custom06–25 and Custom26–40 textures, which robosuite 1.5 does not ship."""

CAMERA_RANGES = {"camera_easy": (0.12, 0.12, 10.0), "camera_hard": (0.16, 0.16, 20.0)}
"""RL-ViGen ``robo_setting.yaml``: position (m, per axis), rotation (rad), field of view (±degrees)."""

SCENE_TEXTURES = {level: ByTask({task: tuple(name for name in names if level != "hard" or name not in BACKGROUND_TEXTURES)
                                   for task, names in TEXTURES.items()}) for level in SCENE_LEVELS}
"""The textures each scene level replaces: all of :data:`TEXTURES`, except the floor and walls under ``hard``'s video."""

OBJECT_PARTS = ByTask({"door": ("Door_",), "lift": ("cube",), "two-arm-peg-in-hole": ("hole", "peg")})
"""Name prefixes of each task's object materials and geoms."""

OBJECT_TEXTURES = ByTask({task: tuple(name for name in names[2:] if not name.startswith("tex-")) for task, names in TEXTURES.items()})
"""Each task's object textures (door wood and metal, the cube, the peg and hole)."""

TABLE_TEXTURES = ByTask({"door": ("tex-ceramic", "tex-steel-brushed"), "lift": ("tex-ceramic", "tex-steel-brushed"),
                         "two-arm-peg-in-hole": ()})
"""The table top and legs (the two-arm task has no table)."""


@dataclass(frozen=True)
class TextureSet:
    """A scene level's texture set, loaded at the first reset: robosuite's texture files, then generated stand-ins."""

    level: str

    def __call__(self) -> ImageBank:
        return texture_bank(self.level)

    def __repr__(self) -> str:
        return f"texture_bank({self.level!r})"


LOCAL_COLORS = Step(RandomMaterialColors, {"mix": 0.2, "exclude": ROBOT_PARTS})
MOVING_SPOT_LIGHT = Step(RandomLighting, {"position_offset": None, "diffuse_offset": None, "moving_step": 0.03, "moving_range": 3.0,
                                          "height": 4.0, "directional": False, "cast_shadow": True})


def scene_textures(level: str) -> Step:
    """The textures of a scene level: one image per texture from the level's set, fixed by the scene id."""
    return Step(RandomTextures, {"textures": SCENE_TEXTURES[level], "images": TextureSet(level),
                                 "scene_id": SceneIndex(SCENES * SCENE_LEVELS.index(level))})


def camera_jitter(level: str) -> Step:
    position, rotation, fov = CAMERA_RANGES[level]
    return Step(RandomCamera, {"position": position, "rotation_deg": math.degrees(rotation), "fov_deg": (-fov, fov)})


LEVELS: dict[str, Level] = {
    "train": Level("robosuite's default scene", "RL-ViGen train"),
    "easy": Level(
        "new floor, wall, table and object textures per scene; non-robot colours 0.8·default + 0.2·U(0, 1)",
        "RL-ViGen eval-easy (SECANT presets)",
        (scene_textures("easy"), LOCAL_COLORS),
    ),
    "medium": Level(
        "easy's colours, the medium texture set, the robot in one random colour, a moving spot light with shadows from z = 4",
        "RL-ViGen eval-medium (SECANT presets)",
        (scene_textures("medium"), LOCAL_COLORS, Step(RandomMaterialColors, {"mix": 1.0, "include": ROBOT_PARTS[:2], "shared": True}),
         MOVING_SPOT_LIGHT),
    ),
    "hard": Level(
        "the hard texture set, the scene's video behind the robot (floor and walls), a moving light",
        "RL-ViGen eval-hard (SECANT presets, DMC-GB videos)",
        (scene_textures("hard"), LOCAL_COLORS, MOVING_SPOT_LIGHT,
         Step(VideoBackground, {"floor": True, "background": ("wall",), "video": SceneIndex()})),
    ),
    "camera_easy": Level("camera moved ± 0.12 m, turned up to 0.12 rad about each of its axes, field of view ± 10°; easy's colours",
                         "RL-ViGen cam-easy (one random axis there)", (LOCAL_COLORS, camera_jitter("camera_easy"))),
    "camera_hard": Level("camera moved ± 0.16 m, turned up to 0.16 rad about each of its axes, field of view ± 20°; easy's colours",
                         "RL-ViGen cam-hard (one random axis there)", (LOCAL_COLORS, camera_jitter("camera_hard"))),
    **{
        f"robot_{robot.lower()}": Level(f"the {robot} arm instead of the Panda, same controller", "RL-ViGen cross-embodiment",
                                        env_options={"robot": robot})
        for robot in ROBOTS[1:]
    },
}
"""Level name -> what it shows, its source, its transforms (parameters may follow the task or scene id) and env options."""

GROUPS: dict[str, list[str]] = {
    "rlvigen": ["easy", "medium", "hard"],
    "camera": ["camera_easy", "camera_hard"],
    "embodiment": [f"robot_{robot.lower()}" for robot in ROBOTS[1:]],
    "all": list(LEVELS),
}

FACTORS: dict[str, Factor] = {
    "background_color": Factor((Step(RandomMaterialColors, {"mix": Scaled(1.0), "include": ("floor", "wall")}),)),
    "object_color": Factor((Step(RandomMaterialColors, {"mix": Scaled(1.0), "include": OBJECT_PARTS}),)),
    "table_color": Factor((Step(RandomMaterialColors, {"mix": Scaled(1.0), "include": ("table",)}),)),
    "floor_texture": Factor((Step(RandomTextures, {"textures": ("texplane",), "blend": Scaled(1.0)}),)),
    "table_texture": Factor((Step(RandomTextures, {"textures": TABLE_TEXTURES, "blend": Scaled(1.0)}),)),
    "object_texture": Factor((Step(RandomTextures, {"textures": OBJECT_TEXTURES, "blend": Scaled(1.0)}),)),
    "video_background": Factor((Step(VideoBackground, {"floor": True, "background": ("wall",), "alpha": Scaled(1.0)}),)),
    "light_position": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "position_jitter": Scaled((2.0, 2.0, 1.0)), "height": 4.0,
                                                    "directional": False}),)),
    "light_color": LIGHT_COLOR,
    "moving_light": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "moving_step": Scaled(0.1), "moving_range": 3.0, "height": 4.0,
                                                  "directional": False, "cast_shadow": True}),)),
    "camera_position": Factor((Step(RandomCamera, {"position": Scaled(0.4)}),)),
    "camera_rotation": CAMERA_ROTATION,
    "camera_fov": CAMERA_FOV,
    "dynamic_camera": Factor((Step(DistractingCamera, {"scale": Scaled(1.0), "dynamic": True, "camera": "agentview",
                                                      "limit_to_upper_quadrant": False}),)),
    "dynamic_color": DYNAMIC_COLOR,
    "embodiment": Factor(env_options={"robot": Choice(ROBOTS[1:])},
                         points={f"robot_{robot.lower()}": (index + 1) / len(ROBOTS[1:]) for index, robot in enumerate(ROBOTS[1:])}),
    **pixel_corruption_factors(),
}
"""Factor name -> its transforms at intensity ``x`` (and env options: ``embodiment`` picks the arm)."""


def texture_bank(level: str) -> ImageBank:
    """The level's texture set: robosuite's texture files, then generated test-side stand-ins for SECANT's custom textures."""
    import robosuite

    folder = Path(robosuite.__file__).parent / "models" / "assets" / "textures"
    generated = ImageBank.stand_in(GENERATED_TEXTURES[level], size=256, seed=SCENE_LEVELS.index(level))
    files = ROBOSUITE_TEXTURES[level]
    if not files:
        return generated
    return ImageBank.from_files([folder / f"{name}.png" for name in files], size=256) + generated


ROBOSUITE = Suite(
    name="robosuite",
    about="robosuite manipulation, robosuite/<task> (e.g. robosuite/door); extra [robosuite]",
    tasks=lambda: list(TASKS),
    build_base=RobosuitePixelEnv,
    levels=LEVELS,
    groups=GROUPS,
    factors=FACTORS,
    example_task="door",
    env_options={"robot": "Panda", "image_size": 84, "camera": "agentview", "episode_length": 500, "control_freq": 20,
                 "reward_shaping": True, "render_settings": None, "device": "cpu"},
    scenes=SCENES,
    install='pip install -e ".[robosuite]"',
)
"""The robosuite suite record."""
