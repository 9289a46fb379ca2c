"""DMC-GB's colour shifts: floor grid, skybox and the agent's body, recoloured in the live model."""

from __future__ import annotations

import importlib
import io
import os
import pickle
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import torch

from vigen.transforms.scene import Defaults, SceneHandle, SceneParams, ScenePerturbation

PARTS = ("grid", "skybox", "self")
PALETTE_KEYS = ("grid_rgb1", "grid_rgb2", "skybox_rgb", "self_rgb")


def load_dmcgb_palette(path: str | os.PathLike) -> list[dict[str, np.ndarray]]:
    """Read a DMC-GB colour preset file (``color_easy.pt`` / ``color_hard.pt``) without running its code.

    The files are pickled lists of dicts of NumPy arrays: DMC-GB's own are ``torch.save`` output
    in PyTorch's legacy format, and ``pickle.dump`` output (any protocol, 0–5) or ``torch.save``
    zip archives are read too. Pickles are read by a restricted unpickler that builds only
    containers, NumPy arrays, dtypes and scalars: any other global (``os.system``, ``exec``, ...)
    is refused with a :class:`pickle.UnpicklingError` before it is called. Zip archives go through
    ``torch.load(weights_only=True)``. Every entry must hold the four keys ``grid_rgb1``,
    ``grid_rgb2``, ``skybox_rgb``, ``self_rgb``, each three finite values in [0, 1].

    Examples:
        >>> import pickle, tempfile, pathlib
        >>> import numpy as np
        >>> entry = {key: np.array([0.2, 0.4, 0.6]) for key in PALETTE_KEYS}
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "color_mine.pt"
        >>> _ = path.write_bytes(pickle.dumps([entry]))
        >>> palette = load_dmcgb_palette(path)
        >>> len(palette), sorted(palette[0]), palette[0]["self_rgb"].tolist()
        (1, ['grid_rgb1', 'grid_rgb2', 'self_rgb', 'skybox_rgb'], [0.2, 0.4, 0.6])
    """
    path = Path(path).expanduser()
    if not path.is_file():
        raise FileNotFoundError(f"DMC-GB palette {path} does not exist (expected src/env/data/color_{{easy,hard}}.pt).")
    data = path.read_bytes()
    if not data:
        raise ValueError(f"DMC-GB palette {path} is empty (0 bytes); copy it again from DMC-GB's src/env/data/.")
    if data.startswith(_ZIP_MAGIC):
        entries = _load_torch_zip(path)
    else:
        allowed = _allowed_globals()
        try:
            entries = _load_pickle_stream(path, data, allowed)
        except PalettePickleRefused:
            raise
        except _HoldsTensors:
            entries = _load_torch_zip(path)
        except Exception as error:
            raise ValueError(
                f"DMC-GB palette {path} could not be read as a pickle ({type(error).__name__}: {error}); the file is "
                "truncated or not a palette. Copy it again from DMC-GB's src/env/data/."
            ) from error
    return _check_palette(entries, path)


class PalettePickleRefused(pickle.UnpicklingError):
    """A palette file asked for a global that is not a container, NumPy array, dtype or scalar."""


class _HoldsTensors(Exception):
    """A legacy ``torch.save`` file holds tensors, which ``torch.load(weights_only=True)`` reads."""


_ZIP_MAGIC = b"PK\x03\x04"
_TORCH_LEGACY_MAGIC = 0x1950A86A20F9469CFC6C
_TORCH_LEGACY_PROTOCOL = 1001


def _latin1_encode(text: str, encoding: str = "utf-8") -> bytes:
    """``_codecs.encode`` as Python-2-compatible pickles use it (bytes stored as latin-1 text), and nothing else."""
    if not isinstance(text, str) or encoding != "latin1":
        raise PalettePickleRefused(f"_codecs.encode is only allowed as encode(str, 'latin1'), got encoding {encoding!r}.")
    return text.encode("latin1")


def _allowed_globals() -> dict[tuple[str, str], Any]:
    """The globals a pickle of lists / dicts of NumPy arrays needs, under NumPy 1 and NumPy 2 module names."""
    multiarray, numeric = _numpy_core("multiarray"), _numpy_core("numeric")
    allowed: dict[tuple[str, str], Any] = {
        ("numpy", "ndarray"): np.ndarray,
        ("numpy", "dtype"): np.dtype,
        ("_codecs", "encode"): _latin1_encode,
    }
    for package in ("numpy.core", "numpy._core"):
        allowed[(f"{package}.multiarray", "_reconstruct")] = multiarray._reconstruct
        allowed[(f"{package}.multiarray", "scalar")] = multiarray.scalar
        allowed[(f"{package}.numeric", "_frombuffer")] = numeric._frombuffer
    for dtype in ("float16", "float32", "float64", "int8", "int16", "int32", "int64", "uint8", "bool"):
        kind = type(np.dtype(dtype))
        allowed[("numpy.dtypes", kind.__name__)] = kind
    return allowed


def _numpy_core(name: str) -> Any:
    """``numpy._core.<name>`` (NumPy 2), else ``numpy.core.<name>`` (NumPy 1, without a deprecation warning)."""
    try:
        return importlib.import_module(f"numpy._core.{name}")
    except ImportError:
        return importlib.import_module(f"numpy.core.{name}")


class _PaletteUnpickler(pickle.Unpickler):
    def __init__(self, file: io.BytesIO, path: Path, allowed: dict[tuple[str, str], Any], torch_file: bool = False) -> None:
        super().__init__(file)
        self.path, self.allowed, self.torch_file = path, allowed, torch_file

    def find_class(self, module: str, name: str) -> Any:
        found = self.allowed.get((module, name))
        if found is None and self.torch_file and module.split(".")[0] == "torch":
            raise _HoldsTensors(f"{module}.{name}")
        if found is None:
            raise PalettePickleRefused(
                f"DMC-GB palette {self.path} asks for the global {module}.{name}, which vigen refuses to load: a palette "
                "holds only lists, dicts and NumPy arrays, so this file is not one (or was tampered with). Nothing in it "
                "was run. Use DMC-GB's own color_easy.pt / color_hard.pt, or save plain dicts of arrays."
            )
        return found

    def persistent_load(self, pid: Any) -> Any:
        raise _HoldsTensors(pid)


def _load_pickle_stream(path: Path, data: bytes, allowed: dict[tuple[str, str], Any]) -> Any:
    """A plain pickle, or the object of a legacy ``torch.save`` file (magic number, version, sys info, object)."""
    stream = io.BytesIO(data)
    first = _PaletteUnpickler(stream, path, allowed).load()
    if not (isinstance(first, int) and first == _TORCH_LEGACY_MAGIC):
        return first
    version = _PaletteUnpickler(stream, path, allowed).load()
    if version != _TORCH_LEGACY_PROTOCOL:
        raise ValueError(f"unknown torch.save legacy protocol version {version!r}")
    _PaletteUnpickler(stream, path, allowed).load()  # sys info: byte order and type sizes
    return _PaletteUnpickler(stream, path, allowed, torch_file=True).load()


def _load_torch_zip(path: Path) -> Any:
    allowed = [_numpy_core("multiarray")._reconstruct, np.ndarray, np.dtype, *{type(np.dtype(t)) for t in ("float64", "float32")}]
    try:
        with torch.serialization.safe_globals(allowed):
            return torch.load(path, weights_only=True)
    except pickle.UnpicklingError as error:
        refused = re.search(r"GLOBAL ([\w.]+)", str(error))
        what = f"the global {refused.group(1)}" if refused else "an object that is not a tensor, container or NumPy array"
        raise PalettePickleRefused(
            f"DMC-GB palette {path} asks for {what}, which vigen refuses to load: a palette holds only lists, dicts and "
            "arrays. Nothing in it was run. Use DMC-GB's own color_easy.pt / color_hard.pt."
        ) from error
    except Exception as error:
        raise ValueError(
            f"DMC-GB palette {path} could not be read as a torch.save file ({type(error).__name__}: {error}); it is "
            "truncated or not a palette. Copy it again from DMC-GB's src/env/data/."
        ) from error


def _check_palette(entries: Any, path: Path) -> list[dict[str, np.ndarray]]:
    """Each entry as four float64 RGB triples in [0, 1], or a ValueError naming the file, entry and key."""
    if not isinstance(entries, (list, tuple)) or not entries:
        raise ValueError(
            f"{path} is not a DMC-GB palette: expected a non-empty list of dicts with keys {PALETTE_KEYS}, got "
            f"{type(entries).__name__}{' (empty)' if isinstance(entries, (list, tuple)) else ''}."
        )
    palette = []
    for index, entry in enumerate(entries):
        if not isinstance(entry, dict) or set(entry) != set(PALETTE_KEYS):
            found = sorted(map(str, entry)) if isinstance(entry, dict) else type(entry).__name__
            raise ValueError(f"{path}, entry {index}: expected a dict with keys {PALETTE_KEYS}, got {found}.")
        colors = {}
        for key in PALETTE_KEYS:
            where = f"{path}, entry {index}, key {key!r}"
            try:
                value = np.asarray(entry[key], dtype=np.float64)
            except (TypeError, ValueError) as error:
                raise ValueError(f"{where}: expected three numbers (RGB in [0, 1]), got {entry[key]!r}.") from error
            if value.size != 3 or value.squeeze().shape != (3,):
                raise ValueError(f"{where}: expected an RGB triple of shape (3,), got shape {value.shape}.")
            if not np.isfinite(value).all():
                raise ValueError(f"{where}: holds non-finite values {value.reshape(3).tolist()}; colours must be in [0, 1].")
            if value.min() < 0 or value.max() > 1:
                raise ValueError(
                    f"{where}: values {value.reshape(3).tolist()} are outside [0, 1]; DMC-GB colours are RGB in [0, 1] "
                    "(divide 0–255 colours by 255)."
                )
            colors[key] = value.reshape(3)
        palette.append(colors)
    return palette


class RandomSceneColors(ScenePerturbation):
    """Recolour the floor grid, the skybox and the agent's ``self`` material once per episode (DMC-GB).

    DMC-GB draws one of 100 presets per episode and reloads the physics from rewritten XML;
    vigen edits the live model instead (material colour, and the texture pixels of the grid and
    the skybox, re-uploaded to the render context), which gives the same colours without a
    recompile. Without a palette file, colours are drawn the way the presets were made (measured
    from DMC-GB's files): each channel of ``grid_rgb1``, ``skybox_rgb`` and ``self_rgb`` is its
    default plus N(0, ``scale``²), clipped to [0, 1], and ``grid_rgb2 = grid_rgb1 + 0.1`` (the
    default offset). ``scale`` is 0.1 for DMC-GB's ``color_easy`` and 0.2 for ``color_hard``. With
    ``palette`` (a DMC-GB ``color_*.pt`` file or a list of its entries) one entry is drawn per
    episode, uniformly.

    Texture edits keep each texture's structure: the checker's two tones and the sky gradient's
    two ends are mapped to the new colours, and the sky's white stars stay white.

    Paper: DMC-GB / SODA, https://arxiv.org/abs/2011.13389.

    Args:
        scale: standard deviation of the colour noise (ignored with ``palette``).
        palette: DMC-GB preset file or entries.
        parts: which of ``"grid"``, ``"skybox"``, ``"self"`` to recolour (RL-ViGen's
            ``objects_color`` is ``("self",)``).
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import RandomSceneColors
        >>> env = make_env("dmc/walker-walk").append_transform(RandomSceneColors(scale=0.2, seed=0))
        >>> env.reset()["pixels"].shape
        torch.Size([9, 84, 84])
    """

    def __init__(
        self,
        scale: float = 0.1,
        palette: str | os.PathLike | Sequence[dict[str, Any]] | None = None,
        parts: Sequence[str] = PARTS,
        seed: int | None = None,
    ) -> None:
        unknown = set(parts) - set(PARTS)
        if unknown:
            raise ValueError(f"Unknown parts {sorted(unknown)}; choose from {PARTS}.")
        super().__init__(seed=seed)
        self.scale = scale
        self.palette_source = palette if palette is None or isinstance(palette, (str, os.PathLike)) else "entries"
        self.palette = load_dmcgb_palette(palette) if isinstance(palette, (str, os.PathLike)) else palette
        self.parts = tuple(parts)

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        defaults: Defaults = {}
        if "self" in self.parts:
            material = _named_id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "self")
            defaults["self_material"] = np.array(material)
            defaults["self_rgb"] = model.mat_rgba[material, :3].copy()
        if "grid" in self.parts:
            texture = _named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, "grid")
            raw = _texture(model, texture).reshape(-1, 3)
            packed = (raw[:, 0].astype(np.int32) << 16) | (raw[:, 1].astype(np.int32) << 8) | raw[:, 2]
            values, counts = np.unique(packed, return_counts=True)
            tones = [np.array([(v >> 16) & 255, (v >> 8) & 255, v & 255]) / 255 for v in values[np.argsort(counts)[-2:]]]
            dark, light = sorted(tones, key=np.sum)
            defaults.update(_two_tone(raw, dark, light, "grid"), grid_texture=np.array(texture))
            defaults["grid_rgb1"], defaults["grid_rgb2"] = dark, light
        if "skybox" in self.parts:
            texture = _named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, "skybox")
            raw = _texture(model, texture).reshape(-1, 3)
            sky = torch.from_numpy(raw)[torch.from_numpy(raw != 255).any(dim=1)]  # without the white stars
            top, bottom = sky.amax(dim=0).double().numpy() / 255, sky.amin(dim=0).double().numpy() / 255
            defaults.update(_two_tone(raw, bottom, top, "skybox"), skybox_texture=np.array(texture))
            defaults["skybox_rgb"], defaults["skybox_bottom"] = top, bottom
        return defaults

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        if self.palette is not None:
            entry = self.palette[rng.integers(len(self.palette))]
            return {key: np.asarray(entry[key], dtype=np.float64) for key in PALETTE_KEYS}
        params = {key: np.clip(defaults[key] + rng.normal(0, self.scale, 3), 0, 1) for key in PALETTE_KEYS
                  if key in defaults and key != "grid_rgb2"}
        if "grid_rgb1" in params:
            params["grid_rgb2"] = np.clip(params["grid_rgb1"] + defaults["grid_rgb2"] - defaults["grid_rgb1"], 0, 1)
        return params

    def identity_params(self, defaults: Defaults) -> SceneParams:
        return {key: defaults[key] for key in PALETTE_KEYS if key in defaults}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        model = scene.model
        if "self" in self.parts:
            model.mat_rgba[int(defaults["self_material"]), :3] = params["self_rgb"]
        if "grid" in self.parts:
            _write_two_tone(scene, defaults, "grid", params["grid_rgb1"], params["grid_rgb2"])
        if "skybox" in self.parts:
            _write_two_tone(scene, defaults, "skybox", defaults["skybox_bottom"], params["skybox_rgb"])

    def extra_repr(self) -> str:
        source = f"palette={self.palette_source!s}" if self.palette is not None else f"scale={self.scale}"
        return f"{source}, parts={self.parts}"


def _named_id(model: Any, kind: mujoco.mjtObj, name: str) -> int:
    index = mujoco.mj_name2id(model, kind, name)
    if index < 0:
        raise ValueError(f"The scene has no {kind.name[6:].lower()} named {name!r}; this perturbation needs one.")
    return index


def _texture(model: Any, texture: int) -> np.ndarray:
    """A writable view of one texture's pixels in ``model.tex_data``."""
    start = model.tex_adr[texture]
    size = model.tex_width[texture] * model.tex_height[texture] * model.tex_nchannel[texture]
    return model.tex_data[start : start + size]


def _two_tone(raw: np.ndarray, low: np.ndarray, high: np.ndarray, name: str) -> Defaults:
    """Where each uint8 pixel lies between two colours (``t``), and which lie off that segment (kept as they are)."""
    pixels_t = torch.from_numpy(raw).float().div_(255)
    low_t, direction = torch.from_numpy(low).float(), torch.from_numpy(high - low).float()
    t = ((pixels_t - low_t) @ direction / (direction @ direction)).clamp_(0, 1).mul_(1e5).round_().div_(1e5)
    residual = (pixels_t - low_t - t[:, None] * direction).abs_().amax(dim=1)
    keep = (residual > 2 / 255).numpy()
    return {
        f"{name}_t": t.unsqueeze(-1),
        f"{name}_keep": np.flatnonzero(keep),
        f"{name}_kept": raw[keep].copy(),
    }


def _write_two_tone(scene: SceneHandle, defaults: Defaults, name: str, low: np.ndarray, high: np.ndarray) -> None:
    texture = int(defaults[f"{name}_texture"])
    t, keep = defaults[f"{name}_t"], defaults[f"{name}_keep"]
    low, high = (torch.from_numpy(255 * c).float() for c in (low, high))
    colors = torch.lerp(low, high, t).round_().to(torch.uint8).numpy()  # lerp is exact at t = 0 and 1
    colors[keep] = defaults[f"{name}_kept"]
    _texture(scene.model, texture)[:] = colors.reshape(-1)
    scene.upload_texture(texture)
