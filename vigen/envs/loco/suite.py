"""The ``loco`` suite: RL-ViGen's locomotion tasks on real robot models (Unitree stand / walk, Franka reach / push).

RL-ViGen adds four tasks to its dm_control copy, on MuJoCo Menagerie's Unitree A1 and Franka Panda,
each with its own reward (``envs/DMCVGB``). vigen builds them from installable models (the Go1 for
the A1, see :mod:`vigen.envs.loco.robot_models`; ``model_dir=`` loads Menagerie's), with RL-ViGen's
frames (84×84, a stack of 3, action repeat 2, 10 s episodes) and its generalization knobs as
levels:

* ``color_*``: the background colours of one of DMC-GB's 100 presets per episode, as RL-ViGen's
  ``background`` colour draws them (``randint(100)`` from ``RandomState(seed)`` per reset) and writes
  them into dm_control's ``grid`` and skybox, leaving the robot alone (``dmcvgb/wrappers.py:45–52``).
  The Unitree stands on RL-ViGen's own ``groundplane`` (``scene_{walk,stand}.xml:38-41``), not on ``grid``,
  so there only the sky changes; the Franka's floor is ``grid`` and changes with the sky;
* ``objects_color_*``: the robot shifted by one preset's ``self_rgb − (0.7, 0.5, 0.3)``, drawn the same
  way (``wrappers.py:53-56``), as RL-ViGen's ``self_rgb`` edits of its shared materials
  (``suite/common/settings.py:51-70``): the Unitree's every material, the Franka's shared ``white`` only
  (:data:`~vigen.envs.loco.scene.WHITE_MATERIAL`), unclipped as RL-ViGen writes them. On
  ``franka-push`` RL-ViGen also recolours the box's material, which the box's own ``rgba`` overrides
  (``scene_push.xml``): its box never changes colour, and vigen's does not either (the
  ``object_color`` factor recolours it);
* ``video_*``: the sky replaced by a video; ``video_hard`` also the floor on the Franka. RL-ViGen's
  ``video_hard`` keys its video on black and blacks out ``grid``, which the Unitree does not stand
  on: there both levels replace the sky only. The videos are DMC-GB's ``video_easy`` (10) /
  ``video_hard`` (100), which RL-ViGen plays (``dmcvgb/wrappers.py:291-297``), once fetched
  (``python -m vigen.datasets fetch dmcgb-videos``), in RL-ViGen's order: episode ``k`` plays video
  ``(k + 1) mod n`` (lines 282, 318-321); procedural stand-ins, labelled as such, until then;
* ``light_position_*``, ``light_color_*``, ``moving_light_*``: RL-ViGen's light offsets and motion
  (vigen's bounce by default; RL-ViGen's drift, which never turns, with
  ``level_options={"moving_path": "drift"}``);
* ``camera_*``: RL-ViGen's ``cam_pos``: every camera's world position pinned at its start plus one
  U(±0.08) or U(±0.15) offset per axis, drawn once per seed; a camera on the trunk then stays where
  the robot started while turning with it (the env option ``camera_offset``);
* ``texture_*``: one of 10 textures per level on the Unitree's ground (``groundplane``) or the Franka's table
  (RL-ViGen's ``table_texture``): photographs (easy) or generated patterns (hard);
* ``easy`` / ``hard``: all of the appearance and lighting knobs at once (colours of the background
  and the robot, texture, lights). RL-ViGen's results sheet
  reports Unitree scores at "Easy" and "Hard" without defining them in code; these are vigen's
  reading, not RL-ViGen's definition. Their presets are those RL-ViGen's ``ColorWrapper`` shows
  with all these knobs set: its draws for the background, the robot, the texture and the lights
  share one ``RandomState(seed)``, replayed in its order
  (:class:`~vigen.transforms.scene.rlvigen_draws.RLViGenDraws`); vigen's texture images and light
  offsets come from its own generators;
* ``robot_go2`` / ``robot_aliengo``: cross-embodiment, a policy trained on the Go1 run on another
  Unitree quadruped with the same 12 joints in the same order.

Examples:
    >>> from vigen.envs.loco.suite import LOCO
    >>> LOCO.env_names()
    ['loco/unitree-stand', 'loco/unitree-walk', 'loco/franka-reach', 'loco/franka-push']
    >>> LOCO.groups["rlvigen"]
    ['easy', 'hard']
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from torchrl.envs import DoubleToFloat, EnvBase

from vigen.envs.factors import CAMERA_FOV, CAMERA_ROTATION, DYNAMIC_COLOR, LIGHT_COLOR, NO_LIGHT_SHIFT, pixel_corruption_factors
from vigen.envs.level_types import ByTask, Choice, Derived, Factor, FetchedData, Level, LevelContext, Scaled, StandInImages, Step
from vigen.envs.loco.scene import FLOOR_MATERIAL, MAX_MESH_FACES, WHITE_MATERIAL
from vigen.envs.suite import Suite
from vigen.transforms import (
    DistractingCamera,
    PresetMaterialColors,
    RandomCamera,
    RandomLighting,
    RandomMaterialColors,
    RandomSceneColors,
    RandomTextures,
    VideoBackground,
)
from vigen.transforms.scene.rlvigen_draws import RLViGenDraws

TASKS = ("unitree-stand", "unitree-walk", "franka-reach", "franka-push")
"""RL-ViGen's ``unitree_stand``, ``unitree_walk``, ``franka_reach`` and ``franka_push``."""

ROBOT_PARTS = ("robot",)
"""Name prefix of the robot's materials (every visible robot geom has one, see :mod:`vigen.envs.loco.scene`)."""

RECOLOURED_PARTS = {task: ("robot",) if task.startswith("unitree") else (WHITE_MATERIAL,) for task in TASKS}
"""What RL-ViGen's ``objects_color`` recolours per task: the Unitree's materials (``dark`` and ``carbonfibre``, its
only ones), the Franka's shared ``white`` only (``suite/common/settings.py:58-61``; its other materials are the
Panda's own)."""

OBJECT_PARTS = {task: ("robot", "object") if task == "franka-push" else ("robot",) for task in TASKS}
"""What the ``object_color`` factor recolours per task: the robot, and the Franka's box (which RL-ViGen's level leaves red)."""

CROSS_EMBODIMENT = ("go2", "aliengo")
"""Unitree quadrupeds a Go1 policy can drive: the same 12 leg joints, in the same order (lightest first)."""

VIDEO_COUNT = {"easy": 10, "hard": 100}
"""DMC-GB's videos per level, which RL-ViGen plays (``dmcvgb/wrappers.py:291-297``)."""

CAMERA_POSITION = {"easy": 0.08, "hard": 0.15}
"""RL-ViGen's ``cam_pos``: U(±0.08) or U(±0.15) per coordinate of the world position (``dmc2gym/wrappers.py:98–106``)."""


@dataclass(frozen=True, repr=False)
class Surface(Derived):
    """The texture RL-ViGen's ``table_texture`` replaces: the Unitree's ground (``groundplane``, RL-ViGen's
    ``ground_texture``) or the Franka's table (``table``).

    Examples:
        >>> Surface()(LevelContext("unitree-walk")), Surface()(LevelContext("franka-push"))
        (('groundplane',), ('table',))
    """

    def __call__(self, context: LevelContext) -> tuple[str, ...]:
        return (FLOOR_MATERIAL["quadruped"],) if context.task.startswith("unitree") else ("table",)

    def __repr__(self) -> str:
        return "unitree: ('groundplane',), franka: ('table',)"


@dataclass(frozen=True, repr=False)
class ByRobot(Derived):
    """One value for the Unitree tasks, another for the Franka tasks.

    Examples:
        >>> ByRobot(("skybox",), ("grid", "skybox"))(LevelContext("unitree-stand"))
        ('skybox',)
    """

    unitree: Any
    franka: Any

    def __call__(self, context: LevelContext) -> Any:
        return self.unitree if context.task.startswith("unitree") else self.franka

    def __repr__(self) -> str:
        return f"unitree: {self.unitree!r}, franka: {self.franka!r}"


BACKGROUND_PARTS = ByRobot(("skybox",), ("grid", "skybox"))
"""What RL-ViGen's ``background`` colour changes on screen: the sky on the Unitree (its floor is ``groundplane``),
the floor ``grid`` and the sky on the Franka."""

VIDEO_FLOOR = ByRobot(False, True)
"""Whether RL-ViGen's ``video_hard`` replaces the floor: it blacks out ``grid`` for its key, the Franka's floor only."""

FLOOR_TEXTURE = ByRobot((FLOOR_MATERIAL["quadruped"],), (FLOOR_MATERIAL["arm"],))
"""The floor's texture: RL-ViGen's ``groundplane`` on the Unitree, dm_control's ``grid`` on the Franka."""


@dataclass(frozen=True, repr=False)
class MainCamera(Derived):
    """The scene's camera 0: the Unitree's ``back_above`` or the Franka's ``side_table``."""

    def __call__(self, context: LevelContext) -> str:
        return "back_above" if context.task.startswith("unitree") else "side_table"

    def __repr__(self) -> str:
        return "unitree: 'back_above', franka: 'side_table'"


def background_colors(difficulty: str, draws: RLViGenDraws | None = None) -> Step:
    """RL-ViGen's ``background`` colour: what it changes on screen (:data:`BACKGROUND_PARTS`) from one of DMC-GB's presets."""
    return Step(RandomSceneColors, {"palette": f"color_{difficulty}", "parts": BACKGROUND_PARTS, "rebuild_textures": True,
                                    **({} if draws is None else {"rlvigen_draws": draws})})


def robot_colors(difficulty: str, draws: RLViGenDraws | None = None) -> Step:
    """RL-ViGen's Menagerie recolouring: the recoloured materials (:data:`RECOLOURED_PARTS`) shifted by one DMC-GB preset's
    ``self_rgb − (0.7, 0.5, 0.3)``."""
    return Step(PresetMaterialColors, {"palette": f"color_{difficulty}", "include": ByTask(RECOLOURED_PARTS),
                                       **({} if draws is None else {"rlvigen_draws": draws})})


def video(difficulty: str) -> Level:
    """RL-ViGen's loco ``video_{difficulty}``: DMC-GB's videos once fetched, episode ``k`` on video ``(k + 1) mod n``."""
    where = "sky" if difficulty == "easy" else "sky (Unitree) or sky and floor (Franka)"
    return Level(
        f"{where} replaced by a video, new frame every step; episode k plays video (k + 1) mod n, as RL-ViGen does",
        f"RL-ViGen video {difficulty} (dmcvgb/wrappers.py:282, 291-297, 318-321: DMC-GB's {VIDEO_COUNT[difficulty]} "
        f"video_{difficulty} videos once fetched: python -m vigen.datasets fetch dmcgb-videos; procedural stand-ins until then, "
        "or a folder given as level_options={'videos': ...}"
        + ("; it blacks out grid, the Franka's floor only)" if difficulty == "hard" else ")"),
        (Step(VideoBackground, {"floor": False if difficulty == "easy" else VIDEO_FLOOR, "first_video": 1,
                                "videos": FetchedData("dmcgb-videos", f"video_{difficulty}", suite="loco")}),),
    )


def textures(difficulty: str) -> Step:
    """One of 10 textures per level on the ground or the table: wood and marble (easy) or high-contrast patterns (hard).

    RL-ViGen's easy set is marble, wood, metal and granite photographs, its hard set city photos,
    foil and tennis-ball patterns, 10 image files each; vigen generates test-side stand-ins
    (:class:`~vigen.envs.level_types.StandInImages`): wood and marble, then warped checkerboards
    and rectangle mosaics, none of them drawn from the overlay augmentations' images.
    """
    kinds = ("wood", "marble") if difficulty == "easy" else ("checker", "mosaic")
    images = StandInImages(10, 256, seed=200 + ("easy", "hard").index(difficulty), kinds=kinds)
    return Step(RandomTextures, {"textures": Surface(), "images": images})


def lighting(difficulty: str) -> Step:
    return Step(RandomLighting, dict(RandomLighting.LEVELS[difficulty]))


def combined(difficulty: str) -> tuple[Step, ...]:
    """``easy`` / ``hard``: background colours (``color``), robot colours (``objects_color``), texture and lights, at one difficulty.

    The two colour steps replay the draws RL-ViGen's ``ColorWrapper`` makes with all these knobs set (:data:`COMBINED_DRAWS`).
    """
    draws = COMBINED_DRAWS[difficulty]
    return background_colors(difficulty, draws), robot_colors(difficulty, draws), textures(difficulty), lighting(difficulty)


COMBINED_DRAWS = {
    difficulty: RLViGenDraws(background=True, objects=True, texture=True,
                             light_position=RandomLighting.LEVELS[difficulty]["position_offset"],
                             light_color=RandomLighting.LEVELS[difficulty]["diffuse_offset"])
    for difficulty in ("easy", "hard")
}
"""The knobs of RL-ViGen's config the ``easy`` / ``hard`` levels set: every draw its ``ColorWrapper.reset`` makes per episode."""


LEVELS: dict[str, Level] = {
    "train": Level("the clean training scene", "all"),
    **{
        f"color_{d}": Level(f"sky (Unitree) or floor and sky (Franka) colours from one of DMC-GB's 100 color_{d} presets per "
                            "episode, drawn as RL-ViGen draws it for the env seed (the robot keeps its colours)",
                            f"RL-ViGen background color {d} (dmcvgb/wrappers.py:45-52: DMC-GB's color_{d} presets, shipped; "
                            "the Unitree's floor is its own groundplane, scene_{walk,stand}.xml:38-41)",
                            (background_colors(d),))
        for d in ("easy", "hard")
    },
    **{
        f"objects_color_{d}": Level(f"robot shifted by one of DMC-GB's 100 color_{d} presets per episode, self_rgb − (0.7, 0.5, "
                                    "0.3), drawn as RL-ViGen draws it: the Unitree's materials, the Franka's white ones (the "
                                    "push box stays red, as in RL-ViGen)",
                                    f"RL-ViGen objects_color {d} (dmcvgb/wrappers.py:53-56, suite/common/settings.py:51-70; "
                                    f"DMC-GB's color_{d} presets, shipped)", (robot_colors(d),))
        for d in ("easy", "hard")
    },
    **{f"video_{d}": video(d) for d in ("easy", "hard")},
    **{
        f"texture_{d}": Level(f"ground (Unitree) or table (Franka) texture: one of 10 {kind}",
                              f"RL-ViGen table_texture {d} (vigen's images; RL-ViGen's are its own files)", (textures(d),))
        for d, kind in (("easy", "generated wood and marble textures"), ("hard", "generated warped checkerboards and mosaics"))
    },
    **{
        f"light_position_{d}": Level(f"every light moved by an integer in {{{lo}, {hi}}} per coordinate", f"RL-ViGen light_position {d}",
                                     (Step(RandomLighting, {"position_offset": (lo, hi), "diffuse_offset": None}),))
        for d, (lo, hi) in (("easy", (3, 4)), ("hard", (9, 10)))
    },
    **{
        f"light_color_{d}": Level(f"light diffuse colour ± U({w})", f"RL-ViGen light_color {d}",
                                  (Step(RandomLighting, {"position_offset": None, "diffuse_offset": w}),))
        for d, w in (("easy", 0.2), ("hard", 10.0))
    },
    **{
        f"moving_light_{d}": Level(f"lights moving {step}/step, bouncing within ± {span} (the height within start … start + "
                                   f"{span:g}, never below the floor); RL-ViGen's drift, +{step}/step on every axis without "
                                   f"turning (+{500 * step:g} by step 500), with level_options={{'moving_path': 'drift'}}",
                                   f"RL-ViGen moving_light {d} (dmcvgb/wrappers.py:35-40, 92-98; its turn check never fires, "
                                   "so its lights drift)",
                                   (Step(RandomLighting, {**NO_LIGHT_SHIFT, "moving_step": step, "moving_range": span}),))
        for d, step, span in (("easy", 0.01, 5.0), ("hard", 0.05, 10.0))
    },
    **{
        f"camera_{d}": Level(f"cameras pinned at their start world position + U(±{p}) per axis (drawn once per seed); "
                             "a trunk camera turns with the robot but does not follow it",
                             f"RL-ViGen cam_pos {d} (dmc2gym/wrappers.py:98-106, 203-204)", env_options={"camera_offset": p})
        for d, p in CAMERA_POSITION.items()
    },
    "easy": Level("color_easy + objects_color_easy + texture_easy + RL-ViGen's easy lights (position {3, 4}, diffuse ± 0.2, moving 0.01/step); the two presets "
                  "per episode are those RL-ViGen's ColorWrapper draws with all these knobs set (one RandomState(seed), its order)",
                  "vigen's reading of RL-ViGen's locomotion Easy (its knobs at easy; the sheet does not define it)", combined("easy")),
    "hard": Level("color_hard + objects_color_hard + texture_hard + RL-ViGen's hard lights (position {9, 10}, diffuse ± 10, moving 0.05/step); the two presets "
                  "per episode are those RL-ViGen's ColorWrapper draws with all these knobs set (one RandomState(seed), its order)",
                  "vigen's reading of RL-ViGen's locomotion Hard (its knobs at hard; the sheet does not define it)", combined("hard")),
    **{
        f"robot_{robot}": Level(f"the Unitree {robot.capitalize()} instead of the Go1, same joints and servos",
                                "RL-ViGen cross-embodiment (DMC: train on one robot, test on another)", env_options={"robot": robot},
                                tasks=("unitree-stand", "unitree-walk"))
        for robot in CROSS_EMBODIMENT
    },
}
"""Level name -> what it shows, its source, and its transforms with their exact parameters."""

GROUPS: dict[str, list[str]] = {
    "rlvigen": ["easy", "hard"],
    "knobs": [name for name in LEVELS if name not in ("train", "easy", "hard") and not name.startswith("robot_")],
    "embodiment": [f"robot_{robot}" for robot in CROSS_EMBODIMENT],
    "all": list(LEVELS),
}

FACTORS: dict[str, Factor] = {
    "background_color": Factor((Step(RandomSceneColors, {"scale": Scaled(1.0), "parts": BACKGROUND_PARTS}),)),
    "object_color": Factor((Step(RandomMaterialColors, {"mix": 0.0, "shift": Scaled(1.0), "shared": True, "include": ByTask(OBJECT_PARTS)}),)),
    "floor_texture": Factor((Step(RandomTextures, {"textures": FLOOR_TEXTURE, "blend": Scaled(1.0)}),)),
    "table_texture": Factor((Step(RandomTextures, {"textures": Surface(), "blend": Scaled(1.0)}),)),
    "video_background": Factor((Step(VideoBackground, {"alpha": Scaled(1.0)}),)),
    "light_position": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "position_jitter": Scaled((10.0, 10.0, 10.0))}),)),
    "light_color": LIGHT_COLOR,
    "moving_light": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "moving_step": Scaled(0.05), "moving_range": 10.0}),)),
    "camera_position": Factor((Step(RandomCamera, {"position": Scaled(0.3)}),)),
    "camera_rotation": CAMERA_ROTATION,
    "camera_fov": CAMERA_FOV,
    "dynamic_camera": Factor((Step(DistractingCamera, {"scale": Scaled(1.0), "dynamic": True, "camera": MainCamera(),
                                                      "limit_to_upper_quadrant": False}),)),
    "dynamic_color": DYNAMIC_COLOR,
    "embodiment": Factor(env_options={"robot": Choice(CROSS_EMBODIMENT)},
                         points={f"robot_{robot}": (index + 1) / len(CROSS_EMBODIMENT) for index, robot in enumerate(CROSS_EMBODIMENT)}),
    **pixel_corruption_factors(),
}
"""Factor name -> its transforms at intensity ``x`` (``embodiment``: the Unitree tasks only).

``object_color`` and ``camera_position`` vary what ``objects_color_*`` and ``camera_*`` vary, the sensible way
rather than the source's: the first recolours the push box too, the second moves each camera in its body's
frame once per episode (a trunk camera follows the robot). So those levels are not points on them."""


def build_loco_base(task: str, *, seed: int | None = None, **options: Any) -> EnvBase:
    """The raw-frame base env of ``"loco/<task>"``: a :class:`~vigen.envs.loco.env.LocoPixelEnv` (imports dm_control)."""
    from vigen.envs.loco.env import LocoPixelEnv

    return LocoPixelEnv(task, seed=seed, **options)


LOCO = Suite(
    name="loco",
    about="RL-ViGen's locomotion tasks on real robot models, loco/<task> (unitree-stand, unitree-walk, franka-reach, "
          "franka-push); extra [loco]",
    tasks=lambda: list(TASKS),
    build_base=build_loco_base,
    levels=LEVELS,
    groups=GROUPS,
    factors=FACTORS,
    example_task="unitree-stand",
    env_options={"robot": None, "model_dir": None, "max_mesh_faces": MAX_MESH_FACES, "action_repeat": 2, "image_size": 84, "camera_id": 0,
                 "episode_length": 1000, "render_settings": None, "action_mapping": "scaled", "time_limit_as": "truncated",
                 "camera_offset": 0.0, "start_clearance": None, "device": "cpu"},
    extra_transforms=lambda: (DoubleToFloat(),),
    install='pip install -e ".[loco]"',
)
"""The loco suite record."""
