"""The ``dmc`` suite: dm_control tasks as pixel envs (DrQ-v2's setup), with DMC-GB's, RL-ViGen's and ImageNet-C's levels.

The suite record :data:`DMC` holds the task names, the builder (:mod:`vigen.envs.dmc.env`, which
imports dm_control when the first env is built), the level table, groups and factors.

Examples:
    >>> from vigen.envs.dmc.suite import DMC
    >>> DMC.levels["color_hard"].steps
    (RandomSceneColors(palette='color_hard', scale=0.2, rebuild_textures=True, dmcgb2_file='color_hard.pt'),)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from torchrl.envs import DoubleToFloat, EnvBase

from vigen.envs.factors import CAMERA_FOV, CAMERA_ROTATION, DYNAMIC_COLOR, LIGHT_COLOR, NO_LIGHT_SHIFT, pixel_corruption_factors
from vigen.envs.level_types import Derived, Factor, FetchedData, Level, LevelContext, Scaled, Step
from vigen.envs.suite import Suite
from vigen.transforms import (
    DistractingCamera,
    DistractingColors,
    DMCGB2Camera,
    DMCGB2VideoBackground,
    PixelCorruption,
    RandomCamera,
    RandomLighting,
    RandomSceneColors,
    RandomTextures,
    VideoBackground,
)
from vigen.transforms.corruptions import SEVERITIES
from vigen.transforms.scene.distracting import DCS_NUM_VIDEOS, DCS_SCALES, dcs_ground_plane_alpha

CORRUPTION_SOURCE = "ImageNet-C severities (Hendrycks & Dietterich 2019)"
DMCGB2_SOURCE = "DMC-GB2 (aalmuzairee/dmcgb2, envs/dmcgb/dmcgb_geometric.py, 2025-07)"
DCS_SOURCE = "DMC-GB's Distracting Control Suite variant (nicklashansen/dmcontrol-generalization-benchmark, src/env/distracting_control)"


@dataclass(frozen=True, repr=False)
class Domain(Derived):
    """The task's dm_control domain (``"walker"`` for ``"walker-walk"``).

    Examples:
        >>> Domain()(LevelContext("ball_in_cup-catch"))
        'ball_in_cup'
    """

    def __call__(self, context: LevelContext) -> str:
        return context.task.partition("-")[0]

    def __repr__(self) -> str:
        return "domain"


@dataclass(frozen=True, repr=False)
class ByDomain(Derived):
    """A value per dm_control domain, ``default`` for the others.

    Examples:
        >>> ByDomain({"quadruped": 2}, 0)(LevelContext("quadruped-run")), ByDomain({"quadruped": 2}, 0)(LevelContext("walker-walk"))
        (2, 0)
    """

    table: Mapping[str, Any]
    default: Any

    def __call__(self, context: LevelContext) -> Any:
        return self.table.get(context.task.partition("-")[0], self.default)

    def __repr__(self) -> str:
        return f"by domain: {dict(self.table)!r}, else {self.default!r}"


@dataclass(frozen=True, repr=False)
class GroundPlaneAlpha(Derived):
    """DCS's ground-plane alpha of the task's domain, the ``grid`` material's (reacher 0, walker and cheetah 1, others 0.3)."""

    def __call__(self, context: LevelContext) -> float:
        return dcs_ground_plane_alpha(context.task.partition("-")[0])

    def __repr__(self) -> str:
        return "dcs_ground_plane_alpha(domain)"


DCS_CAMERA = {"camera": ByDomain({"quadruped": 2}, 0), "limit_to_upper_quadrant": ByDomain({"reacher": False}, True)}
"""DCS's camera settings: the env's camera (quadruped: 2), and the upper-quadrant limit except for reacher."""


def dcs_level(scale: float, dynamic: bool) -> Level:
    """DMC-GB's Distracting Control Suite setting at intensity ``scale``: camera, colours and background video together.

    The dynamic levels move camera, colours and video on every 2nd control step (a dm_control
    physics step of the task's ``control_timestep``; the walker takes 10 MuJoCo steps per control
    step), counted from the reset, as DMC-GB's copy does (``update_every=2``; the original suite
    moves on every one: ``level_options={"update_every": 1}``). A video folder is read as DAVIS 2017
    and its ``train`` split played, as DCS does (``level_options={"split": None}``: every video under
    the folder). The video is drawn into the sky texture, as DCS draws it (one square face on every
    side of the sky cube, so the camera's walk pans across it; ``sky_size`` sets the face's side,
    default the texture's width, 800 as in DCS for videos from a folder); ``level_options={"skybox":
    False}`` pastes it into the frame's sky pixels in screen space instead (vigen's earlier default,
    the ``"composite"``; cost of each in ``docs/fidelity.md``).
    """
    videos = DCS_NUM_VIDEOS[scale]
    motion = "drifting every 2nd control step" if dynamic else "drawn per episode"
    every = {"update_every": 2} if dynamic else {}
    clips = f"the first {videos} DAVIS train videos" if videos else "every DAVIS train video"
    return Level(
        f"DCS at intensity {scale}: camera pose and every material colour {motion}, background video "
        f"({clips}, once fetched: python -m vigen.datasets fetch davis2017; procedural stand-ins without it; "
        f"{'playing back and forth' if dynamic else 'one still frame'}) in the sky texture, panning with the camera as in DCS "
        "(screen-space composite with level_options={'skybox': False})",
        DCS_SOURCE + ("" if dynamic else ", static variant"),
        (Step(DistractingCamera, {"scale": scale, "dynamic": dynamic, **DCS_CAMERA, **every}),
         Step(DistractingColors, {"scale": scale, "dynamic": dynamic, **every}),
         Step(VideoBackground, {"playback": "bounce" if dynamic else "static", "num_videos": videos, "split": "train",
                                "videos": FetchedData("davis2017", subfolder="DAVIS"),
                                "ground_plane_alpha": GroundPlaneAlpha(), "skybox": True, **every})),
    )


def dmcgb_video_level(difficulty: str, floor: bool) -> Level:
    """DMC-GB's ``video_easy`` (the sky) or ``video_hard`` (sky and floor): its videos once fetched, in DMC-GB's order.

    DMC-GB2's order and in-scene screen are level options (``draw``, ``screen``) of the same level.
    """
    count = {"easy": 10, "hard": 100}[difficulty]
    return Level(
        f"{'sky and floor' if floor else 'sky'} replaced by a video, new frame every step; episode k plays video (k + 1) "
        "mod n, as DMC-GB does (DMC-GB2's order, (start + 1 + k) mod n from start = RandomState(seed).randint(100), with "
        "level_options={'draw': 'dmcgb2'}; DMC-GB2's in-scene screen with {'screen': True})",
        f"DMC-GB video_{difficulty} (its {count} videos once fetched: python -m vigen.datasets fetch dmcgb-videos; procedural "
        f"stand-ins until then, or a folder given as level_options={{'videos': ...}}); DMC-GB2 video_{difficulty} (the same "
        "videos, its order and screen by level option)",
        (Step(DMCGB2VideoBackground, {"floor": floor, "draw": "dmcgb", "domain": Domain(),
                                      "videos": FetchedData("dmcgb-videos", f"video_{difficulty}")}),),
    )


def dmcgb2_level(mode: str, difficulty: str) -> Level:
    what = {"rotate": "camera turned about its view axis", "shift": "camera panned and tilted towards the image corners",
            "rotate_shift": "camera panned, tilted and turned"}[mode]
    return Level(f"{what} ({difficulty}), one of 100 presets per episode, in DMC-GB2's order for the env seed", DMCGB2_SOURCE,
                 (Step(DMCGB2Camera, {"mode": mode, "difficulty": difficulty, "domain": Domain()}),))


def dmcgb_color_level(difficulty: str, scale: float) -> Level:
    """DMC-GB's ``color_{difficulty}``: its 100 presets (shipped with vigen), one drawn per episode as DMC-GB draws it.

    ``level_options={"draw": "dmcgb2"}`` cycles the presets as DMC-GB2 does (its ``color_{difficulty}``),
    ``{"palette": "statistics"}`` draws stand-in colours, default + N(0, ``scale``²) per channel, and
    ``{"palette": <file or folder>}`` / ``{"dmcgb2_colors": <file or folder>}`` read a user's copy.
    """
    return Level(
        f"floor, sky and agent colours: one of DMC-GB's 100 color_{difficulty} presets per episode, drawn as DMC-GB "
        f"draws it for the env seed (DMC-GB2's cycle with level_options={{'draw': 'dmcgb2'}}; stand-ins, default + "
        f"N(0, {scale}²) per channel, with {{'palette': 'statistics'}})",
        f"DMC-GB color_{difficulty} (its 100 presets, shipped); DMC-GB2 color_{difficulty} (the same presets, cycled)",
        (Step(RandomSceneColors, {"palette": f"color_{difficulty}", "scale": scale, "rebuild_textures": True,
                                  "dmcgb2_file": f"color_{difficulty}.pt"}),),
    )


def rlvigen_background_level(difficulty: str) -> Level:
    """RL-ViGen's DMC ``background`` colour: floor and sky from one of DMC-GB's ``color_{difficulty}`` presets, the agent left alone."""
    return Level(
        f"floor and sky colours (not the agent's): one of DMC-GB's 100 color_{difficulty} presets per episode, drawn as "
        "RL-ViGen draws it for the env seed (RandomState(seed).randint(100) per reset)",
        f"RL-ViGen background color {difficulty} (envs/DMCVGB/dmcvgb/wrappers.py:45-52: grid_rgb1, grid_rgb2 and skybox_rgb "
        f"of DMC-GB's color_{difficulty} presets, shipped; DMC-GB's color_{difficulty} also recolours the agent)",
        (Step(RandomSceneColors, {"palette": f"color_{difficulty}", "parts": ("grid", "skybox"), "rebuild_textures": True}),),
    )


def rlvigen_objects_level(difficulty: str) -> Level:
    """RL-ViGen's DMC ``objects_color``: the agent's ``self`` colour from one of DMC-GB's ``color_{difficulty}`` presets."""
    return Level(
        f"agent colour only: the self_rgb of one of DMC-GB's 100 color_{difficulty} presets per episode, drawn as RL-ViGen "
        "draws it for the env seed (RandomState(seed).randint(100) per reset)",
        f"RL-ViGen objects_color {difficulty} (envs/DMCVGB/dmcvgb/wrappers.py:53-56; DMC-GB's color_{difficulty} presets, shipped)",
        (Step(RandomSceneColors, {"palette": f"color_{difficulty}", "parts": ("self",)}),),
    )


def rlvigen_light_level(difficulty: str) -> Level:
    """RL-ViGen's ``light_position`` + ``light_color`` + ``moving_light`` at one difficulty; its drift by level option."""
    params = RandomLighting.LEVELS[difficulty]
    low, high = params["position_offset"]
    step, span = params["moving_step"], params["moving_range"]
    return Level(
        f"light position +{{{low}, {high}}}, diffuse ± {params['diffuse_offset']:g}, light moving {step}/step, bouncing within "
        f"± {span:g} (the height within start … start + {span:g}); RL-ViGen's drift, +{step}/step on every axis without "
        f"turning (+{500 * step:g} by step 500), with level_options={{'moving_path': 'drift'}}",
        f"RL-ViGen light_position + light_color + moving_light, {difficulty} (envs/DMCVGB/dmcvgb/wrappers.py:35-40, 80-98)",
        (Step(RandomLighting, dict(params)),),
    )


LEVELS: dict[str, Level] = {
    "train": Level("the clean training scene", "all"),
    **{f"color_{difficulty}": dmcgb_color_level(difficulty, scale) for difficulty, scale in (("easy", 0.1), ("hard", 0.2))},
    **{f"background_color_{difficulty}": rlvigen_background_level(difficulty) for difficulty in ("easy", "hard")},
    **{f"objects_color_{difficulty}": rlvigen_objects_level(difficulty) for difficulty in ("easy", "hard")},
    "floor_texture": Level(
        "floor grid replaced by a texture image",
        "RL-ViGen table_texture (generated stand-in textures)",
        (Step(RandomTextures),),
    ),
    **{f"video_{difficulty}": dmcgb_video_level(difficulty, floor) for difficulty, floor in (("easy", False), ("hard", True))},
    **{f"light_{difficulty}": rlvigen_light_level(difficulty) for difficulty in ("easy", "hard")},
    "camera_easy": Level(
        "camera moved ± 0.08, turned ± 9°, field of view −4° … +5°",
        "RL-ViGen cam_pos easy; DCS camera scale 0.1; RL-ViGen Adroit FOV easy",
        (Step(RandomCamera, {"position": 0.08, "rotation_deg": 9.0, "fov_deg": (-4.0, 5.0)}),),
    ),
    "camera_hard": Level(
        "camera moved ± 0.15, turned ± 27°, field of view ± 10°",
        "RL-ViGen cam_pos hard; DCS camera scale 0.3; RL-ViGen Adroit FOV hard",
        (Step(RandomCamera, {"position": 0.15, "rotation_deg": 27.0, "fov_deg": (-10.0, 10.0)}),),
    ),
    **{f"{mode}_{difficulty}": dmcgb2_level(mode, difficulty) for mode in ("rotate", "shift", "rotate_shift")
       for difficulty in ("easy", "hard")},
    **{
        f"color_video_{difficulty}": Level(
            f"color_{difficulty}'s 100 presets cycled as DMC-GB2 cycles them, and a sky video (the floor stays, "
            "recoloured); colours and videos start from one index seeded by the env seed; DMC-GB2's in-scene video "
            "screen with level_options={'screen': True}",
            f"DMC-GB2 color_video_{difficulty} (its presets, shipped; its video is on an in-scene screen box: vigen "
            "composites by segmentation unless screen=True)",
            (Step(RandomSceneColors, {"palette": f"color_{difficulty}", "draw": "dmcgb2", "scale": scale,
                                      "rebuild_textures": True, "dmcgb2_file": f"color_{difficulty}.pt"}),
             Step(DMCGB2VideoBackground, {"floor": False, "domain": Domain(),
                                          "videos": FetchedData("dmcgb-videos", f"video_{difficulty}")})),
        )
        for difficulty, scale in (("easy", 0.1), ("hard", 0.2))
    },
    **{f"dcs_{scale}": dcs_level(scale, dynamic=True) for scale in DCS_SCALES},
    **{f"dcs_static_{scale}": dcs_level(scale, dynamic=False) for scale in DCS_SCALES},
    **{
        f"{corruption}_{severity}": Level(
            f"{corruption.replace('_', ' ')}, severity {severity} of 5",
            CORRUPTION_SOURCE,
            (Step(PixelCorruption, {"corruption": corruption, "severity": severity}),),
        )
        for corruption in SEVERITIES
        for severity in range(1, 6)
    },
}
"""Level name -> what it shows, its source, and its transforms with their exact parameters."""

GROUPS: dict[str, list[str]] = {
    "dmcgb": ["color_easy", "color_hard", "video_easy", "video_hard"],
    "rlvigen": [
        "background_color_easy", "background_color_hard", "objects_color_easy", "objects_color_hard", "floor_texture",
        "video_easy", "video_hard", "light_easy", "light_hard", "camera_easy", "camera_hard",
    ],
    "dmcgb2": ["color_easy", "color_hard", "video_easy", "video_hard", "color_video_easy", "color_video_hard",
               *(f"{mode}_{difficulty}" for mode in ("rotate", "shift", "rotate_shift") for difficulty in ("easy", "hard"))],
    "dcs": [f"dcs_{scale}" for scale in DCS_SCALES],
    "dcs_static": [f"dcs_static_{scale}" for scale in DCS_SCALES],
    "corruptions": [f"{c}_{s}" for c in SEVERITIES for s in range(1, 6)],
    "all": list(LEVELS),
}

FACTORS: dict[str, Factor] = {
    "background_color": Factor((Step(RandomSceneColors, {"scale": Scaled(1.0), "parts": ("grid", "skybox")}),)),
    "object_color": Factor((Step(RandomSceneColors, {"scale": Scaled(1.0), "parts": ("self",)}),)),
    "floor_texture": Factor((Step(RandomTextures, {"blend": Scaled(1.0)}),), points={"floor_texture": 1.0}),
    "video_background": Factor((Step(VideoBackground, {"alpha": Scaled(1.0)}),)),
    "light_position": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "position_jitter": Scaled((10.0, 10.0, 10.0))}),)),
    "light_color": LIGHT_COLOR,
    "moving_light": Factor((Step(RandomLighting, {**NO_LIGHT_SHIFT, "moving_step": Scaled(0.05), "moving_range": 10.0}),)),
    "camera_position": Factor((Step(RandomCamera, {"position": Scaled(0.5)}),)),
    "camera_rotation": CAMERA_ROTATION,
    "camera_fov": CAMERA_FOV,
    "dynamic_camera": Factor((Step(DistractingCamera, {"scale": Scaled(1.0), "dynamic": True, **DCS_CAMERA}),)),
    "dynamic_color": DYNAMIC_COLOR,
    **pixel_corruption_factors(named_levels=True),
}
"""Factor name -> its transforms at intensity ``x``.

``object_color`` draws default + N(0, x²) per channel of the agent's colour; the ``objects_color_*`` levels show
DMC-GB's presets instead (RL-ViGen's definition), so they are not points on it."""


def dmc_tasks() -> list[str]:
    """The ``"<domain>-<task>"`` names of every dm_control suite task (imports dm_control)."""
    from vigen.envs.dmc.env import task_names

    return task_names()


def build_dmc_base(task: str, *, seed: int | None = None, **options: Any) -> EnvBase:
    """The raw-frame base env of ``"dmc/<domain>-<task>"``: a :class:`~vigen.envs.dmc.env.DMCPixelEnv` (imports dm_control)."""
    from vigen.envs.dmc.env import DMCPixelEnv

    domain, _, name = task.partition("-")
    return DMCPixelEnv(domain, name, seed=seed, **options)


DMC = Suite(
    name="dmc",
    about="dm_control suite tasks, dmc/<domain>-<task> (e.g. dmc/walker-walk)",
    tasks=dmc_tasks,
    build_base=build_dmc_base,
    levels=LEVELS,
    groups=GROUPS,
    factors=FACTORS,
    example_task="walker-walk",
    env_options={"action_repeat": 2, "image_size": 84, "camera_id": None, "episode_length": 1000, "render_settings": None,
                 "device": "cpu"},
    extra_transforms=lambda: (DoubleToFloat(),),
)
"""The dm_control suite record."""

