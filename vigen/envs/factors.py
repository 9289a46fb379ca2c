"""The shared factor vocabulary: one name per kind of visual change, each with an intensity in [0, 1].

Every suite maps the factors that make sense for its scenes to transforms in its
:class:`~vigen.envs.suite.Suite` record (``suite.factors``); ``make_env(name,
generalization={"camera_rotation": 0.3, "object_color": 0.5})`` applies one or several.
Intensity 0 leaves the factor off; 1 is the strongest setting vigen defines. Where a benchmark
has an intensity scale (the Distracting Control Suite's ``s``), the factor uses it, so
``camera_rotation`` at 0.1 / 0.2 / 0.3 is DCS easy / medium / hard.

Examples:
    >>> from vigen.envs.factors import FACTORS
    >>> FACTORS["camera_rotation"]
    'camera turned about its own axes by U(±90°·x) each (DCS: π/2·s)'
"""

from __future__ import annotations

from types import MappingProxyType

from vigen.envs.level_types import Factor, Scaled, Severity, Span, Step
from vigen.transforms import DistractingColors, PixelCorruption, RandomCamera, RandomLighting
from vigen.transforms.corruptions import SEVERITIES

FACTORS: dict[str, str] = {
    "background_color": "floor, sky and walls recoloured: colour noise (std or mix weight) x",
    "object_color": "the agent or the task objects recoloured: colour noise (std or mix weight) x",
    "table_color": "the table recoloured: mix weight x of a random colour",
    "floor_texture": "floor texture replaced by an image, blended with weight x",
    "table_texture": "table texture replaced by an image, blended with weight x",
    "object_texture": "object textures replaced by images, blended with weight x",
    "video_background": "background replaced by a video, blended with alpha x (DCS video_alpha)",
    "light_position": "lights moved by U(±x·range) per axis",
    "light_color": "light diffuse colour offset by U(±x)",
    "moving_light": "lights moving every step, speed ∝ x",
    "camera_position": "camera moved by U(±x·range) per axis",
    "camera_rotation": "camera turned about its own axes by U(±90°·x) each (DCS: π/2·s)",
    "camera_fov": "field of view changed by U(±40°·x)",
    "dynamic_camera": "DCS dynamic camera: pose drifting every step at scale x",
    "dynamic_color": "DCS dynamic colours: every material's colour drifting every step at scale x",
    "embodiment": "another robot of the same kind and action space, further from the training robot as x grows",
    **{name: f"pixel corruption {name.replace('_', ' ')}, severity ⌈5·x⌉ (ImageNet-C)" for name in SEVERITIES},
}
"""Factor name -> what it changes (and how the intensity ``x`` enters)."""


NO_LIGHT_SHIFT = MappingProxyType({"position_offset": None, "diffuse_offset": None})
"""RandomLighting parameters that leave position and colour alone (each lighting factor sets one thing)."""

LIGHT_COLOR = Factor((Step(RandomLighting, {"position_offset": None, "diffuse_offset": Scaled(1.0)}),))
CAMERA_ROTATION = Factor((Step(RandomCamera, {"position": 0.0, "rotation_deg": Scaled(90.0)}),))
CAMERA_FOV = Factor((Step(RandomCamera, {"position": 0.0, "fov_deg": Span(40.0)}),))
DYNAMIC_COLOR = Factor((Step(DistractingColors, {"scale": Scaled(1.0), "dynamic": True}),))


def pixel_corruption_factors(named_levels: bool = False) -> dict[str, Factor]:
    """One factor per ImageNet-C corruption, severity ``⌈5·x⌉``; ``named_levels`` marks ``<corruption>_<s>`` as its points."""
    return {
        corruption: Factor(
            (Step(PixelCorruption, {"corruption": corruption, "severity": Severity()}),),
            points={f"{corruption}_{severity}": severity / 5 for severity in range(1, 6)} if named_levels else {},
        )
        for corruption in SEVERITIES
    }
