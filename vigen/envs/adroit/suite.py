"""Adroit dexterous-hand tasks (gymnasium-robotics) as TorchRL pixel envs, with RL-ViGen's Adroit levels.

RL-ViGen's Adroit setting: 84×84 frames from a fixed camera, a stack of 3, success reported per
episode. vigen builds the gymnasium-robotics models (``AdroitHandDoor/Hammer/Pen``, mujoco 3),
repeats each action twice (VRL3's setting) and renders with its own ``mujoco.Renderer`` at the
target size, so :class:`~vigen.rendering.RenderSettings` apply (gymnasium's renderer keeps a
640×480 buffer with multisampling).

Differences from RL-ViGen's ``mj_envs`` models, which need mujoco-py: the gymnasium-robotics models
have no ``top`` camera (RL-ViGen's door and hammer view) and no skybox, so every task renders from
``vil_camera`` (RL-ViGen's pen view) and the colour levels recolour the floor, table and objects
(the background stays black) while the video levels key the background and floor by segmentation.
"""

from __future__ import annotations

import math

from vigen.envs.adroit.env import TASKS, AdroitPixelEnv
from vigen.envs.factors import CAMERA_FOV, CAMERA_ROTATION, DYNAMIC_COLOR, LIGHT_COLOR, NO_LIGHT_SHIFT, pixel_corruption_factors
from vigen.envs.level_types import Factor, Level, Scaled, StandInImages, Step
from vigen.envs.suite import Suite
from vigen.transforms import (
    DistractingCamera,
    RandomCamera,
    RandomLighting,
    RandomMaterialColors,
    RandomTextures,
    VideoBackground,
)

HAND_PARTS = ("C_", "V_", "MatColl", "MatViz", "forearm", "Adroit", "ARM", "arm")
"""Name prefixes of the hand's and arm's geoms and materials, which the colour levels leave alone."""

TABLE_TEXTURES = ("marble2d", "marblecube")
"""The table top's textures, which the colour and video levels replace (RL-ViGen: one of 10 per level)."""

COLOR_MIX = {"easy": 0.5, "hard": 1.0}
MOVING_LIGHT = {"easy": (0.04, 1.2), "hard": (0.12, 3.0)}
CAMERA = {"camera_easy": (0.03, 0.03, (-4.0, 5.0)), "camera_hard": (0.07, 0.08, (-10.0, 10.0))}
"""Position (per axis), quaternion-component noise (RL-ViGen adds it unnormalised; vigen turns by 2·asin of it per axis), FOV."""
LIGHT = {"light_easy": (0.5, 0.5, 0.2), "light_hard": (1.0, 1.0, 0.5)}




def table_and_colors(difficulty: str) -> tuple[Step, Step]:
    """The colour levels' steps: one of 10 table textures per episode, and floor and object colours mixed with U(0, 1)."""
    tables = StandInImages(10, 256, 100 + ("easy", "hard").index(difficulty))
    return (Step(RandomTextures, {"textures": TABLE_TEXTURES, "images": tables}),
            Step(RandomMaterialColors, {"mix": COLOR_MIX[difficulty], "exclude": HAND_PARTS}))


def moving_light(difficulty: str) -> Step:
    step, moving_range = MOVING_LIGHT[difficulty]
    return Step(RandomLighting, {"position_offset": None, "diffuse_offset": None, "moving_step": step, "moving_range": moving_range,
                                 "moving_axes": (1,)})


def camera_jitter(level: str) -> Step:
    position, quaternion, fov = CAMERA[level]
    return Step(RandomCamera, {"position": position, "rotation_deg": math.degrees(2 * math.asin(quaternion)), "fov_deg": fov})


LEVELS: dict[str, Level] = {
    "train": Level("gymnasium-robotics' default scene", "RL-ViGen train"),
    "color_easy": Level("table texture (10 per level), floor and object colours 0.5·default + 0.5·U(0, 1)",
                        "RL-ViGen color-easy (its parts; vigen's colour ranges)", table_and_colors("easy")),
    "color_hard": Level("table texture (10 per level), floor and object colours U(0, 1)",
                        "RL-ViGen color-hard (its parts; vigen's colour ranges)", table_and_colors("hard")),
    "video_easy": Level("background and floor replaced by a video; easy colours; light moving 0.04/step within ± 1.2 along y",
                        "RL-ViGen video-easy",
                        (*table_and_colors("easy"), moving_light("easy"), Step(VideoBackground, {"floor": True}))),
    "video_hard": Level("background and floor replaced by a video; hard colours; light moving 0.12/step within ± 3 along y",
                        "RL-ViGen video-hard",
                        (*table_and_colors("hard"), moving_light("hard"), Step(VideoBackground, {"floor": True}))),
    "camera_easy": Level("camera moved ± 0.03, turned ± 3.4°, field of view −4° … +5°", "RL-ViGen camera easy (setting.yaml)",
                         (camera_jitter("camera_easy"),)),
    "camera_hard": Level("camera moved ± 0.07, turned ± 9.2°, field of view ± 10°", "RL-ViGen camera hard (setting.yaml)",
                         (camera_jitter("camera_hard"),)),
    **{
        level: Level(f"light moved ± {LIGHT[level]}", f"RL-ViGen light {level[6:]} (setting.yaml)",
                     (Step(RandomLighting, {"position_offset": None, "diffuse_offset": None, "position_jitter": LIGHT[level]}),))
        for level in ("light_easy", "light_hard")
    },
}
"""Level name -> what it shows, its source, and its transforms with their exact parameters."""

GROUPS: dict[str, list[str]] = {
    "rlvigen": ["color_easy", "color_hard", "video_easy", "video_hard"],
    "camera": ["camera_easy", "camera_hard"],
    "light": ["light_easy", "light_hard"],
    "all": list(LEVELS),
}

FLOOR_PARTS = ("groundplane", "MatGnd", "ground", "MatPlane")
"""Name prefixes of the floor's materials and geom."""

OBJECT_PARTS = ("object", "MatFoil", "MatWood", "MatSquare", "board", "handle", "head", "neck", "pen", "top", "bot", "cli")
"""Name prefixes of the door, hammer, nail board and pen materials and geoms."""

FACTORS: dict[str, Factor] = {
    "background_color": Factor((Step(RandomMaterialColors, {"mix": Scaled(1.0), "include": FLOOR_PARTS}),)),
    "object_color": Factor((Step(RandomMaterialColors, {"mix": Scaled(1.0), "include": OBJECT_PARTS}),)),
    "table_color": Factor((Step(RandomMaterialColors, {"mix": Scaled(1.0), "include": ("table",)}),)),
    "floor_texture": Factor((Step(RandomTextures, {"textures": ("groundplane",), "blend": Scaled(1.0)}),)),
    "table_texture": Factor((Step(RandomTextures, {"textures": TABLE_TEXTURES, "blend": Scaled(1.0)}),)),
    "object_texture": Factor((Step(RandomTextures, {"textures": ("wood", "wood2d", "woodb", "foil", "square"), "blend": Scaled(1.0)}),)),
    "video_background": Factor((Step(VideoBackground, {"floor": True, "alpha": Scaled(1.0)}),)),
    "light_position": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "position_jitter": Scaled((1.0, 1.0, 0.5))}),),
                             points={"light_hard": 1.0}),
    "light_color": LIGHT_COLOR,
    "moving_light": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "moving_step": Scaled(0.12), "moving_range": 3.0, "moving_axes": (1,)}),)),
    "camera_position": Factor((Step(RandomCamera, {"position": Scaled(0.2)}),)),
    "camera_rotation": CAMERA_ROTATION,
    "camera_fov": CAMERA_FOV,
    "dynamic_camera": Factor((Step(DistractingCamera, {"scale": Scaled(1.0), "dynamic": True, "camera": "vil_camera",
                                                      "limit_to_upper_quadrant": False}),)),
    "dynamic_color": DYNAMIC_COLOR,
    **pixel_corruption_factors(),
}
"""Factor name -> its transforms at intensity ``x``."""


ADROIT = Suite(
    name="adroit",
    about="Adroit dexterous hand, adroit/<task> (door, hammer, pen); extra [adroit]",
    tasks=lambda: list(TASKS),
    build_base=AdroitPixelEnv,
    levels=LEVELS,
    groups=GROUPS,
    factors=FACTORS,
    example_task="door",
    env_options={"action_repeat": 2, "image_size": 84, "camera": "vil_camera", "episode_length": None, "render_settings": None,
                 "device": "cpu"},
    install='pip install -e ".[adroit]"',
)
"""The Adroit suite record."""
