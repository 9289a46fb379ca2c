"""DMC-GB's colour presets: the shipped copy (:func:`dmcgb_presets`) and a reader for ``color_easy.pt`` / ``color_hard.pt`` files.

vigen ships DMC-GB's two preset lists as plain JSON (``vigen/assets/data/dmcgb_colors.json``, with
DMC-GB's MIT license notice and the repository, commit, file and git blob id they come from), so
the ``color_easy`` / ``color_hard`` levels show the benchmark's own colours without any download.
A user's own preset file (a pickle, as DMC-GB stores them) is read by :func:`load_dmcgb_palette`
without running code.
"""

from __future__ import annotations

import functools
import importlib
import importlib.resources
import io
import json
import os
import pickle
import re
from pathlib import Path
from typing import Any

import numpy as np
import torch

from vigen.datasets import git_blob_id

PALETTE_KEYS = ("grid_rgb1", "grid_rgb2", "skybox_rgb", "self_rgb")
"""The four colours of a DMC-GB preset: floor checker (two tones), sky, and the agent's ``self`` material."""

DMCGB_PRESETS = ("color_easy", "color_hard")
"""The names of DMC-GB's preset lists that ship with vigen (100 entries each)."""

DMCGB_PRESETS_FILE = "dmcgb_colors.json"
"""The file under ``vigen/assets/data`` that holds them, with their license notice and provenance."""


def dmcgb_presets(name: str) -> list[dict[str, np.ndarray]]:
    """DMC-GB's ``color_easy`` or ``color_hard`` presets as shipped with vigen: 100 dicts of four float64 RGB triples.

    The values equal those of DMC-GB's ``src/env/data/color_{easy,hard}.pt`` exactly (see
    :func:`dmcgb_presets_record` for the license notice, the commit and the files' git blob ids).
    Each call returns fresh arrays, so editing them changes nothing for the next caller.

    Examples:
        >>> presets = dmcgb_presets("color_hard")
        >>> len(presets), sorted(presets[0]), presets[0]["grid_rgb1"].dtype
        (100, ['grid_rgb1', 'grid_rgb2', 'self_rgb', 'skybox_rgb'], dtype('float64'))
        >>> dmcgb_presets("colour_hard")
        Traceback (most recent call last):
        ...
        ValueError: Unknown DMC-GB preset list 'colour_hard'; vigen ships 'color_easy' and 'color_hard'.
    """
    if name not in DMCGB_PRESETS:
        raise ValueError(f"Unknown DMC-GB preset list {name!r}; vigen ships 'color_easy' and 'color_hard'.")
    return check_palette(_shipped_presets()["presets"][name], f"vigen's shipped DMC-GB {name} presets")


def dmcgb_presets_record() -> dict[str, Any]:
    """What the shipped presets file says about itself: ``about``, ``license`` (name, copyright, text) and ``provenance``.

    Examples:
        >>> record = dmcgb_presets_record()
        >>> record["license"]["name"], record["provenance"]["commit"][:7]
        ('MIT', 'ff9c0aa')
        >>> record["provenance"]["files"]["color_hard"]["git_blob"][:7]
        'f13f9f4'
    """
    data = _shipped_presets()
    return json.loads(json.dumps({key: data[key] for key in ("about", "license", "provenance")}))  # a copy


def dmcgb_preset_file_part(path: str | os.PathLike) -> str | None:
    """``"color_easy"`` / ``"color_hard"`` when the file at ``path`` is DMC-GB's own preset file (its git blob id), else ``None``.

    Examples:
        >>> import tempfile, pathlib
        >>> other = pathlib.Path(tempfile.mkdtemp()) / "color_hard.pt"
        >>> _ = other.write_bytes(b"not DMC-GB's")
        >>> dmcgb_preset_file_part(other) is None
        True
    """
    blob = git_blob_id(path)
    files = dmcgb_presets_record()["provenance"]["files"]
    return next((name for name, entry in files.items() if entry["git_blob"] == blob), None)


@functools.lru_cache(maxsize=1)
def _shipped_presets() -> dict[str, Any]:
    """The shipped JSON file, parsed once (plain JSON: reading it runs no code)."""
    text = importlib.resources.files("vigen.assets").joinpath("data", DMCGB_PRESETS_FILE).read_text(encoding="utf-8")
    return json.loads(text)


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
    return check_palette(entries, path)


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


def check_palette(entries: Any, path: Path | str = "palette") -> list[dict[str, np.ndarray]]:
    """Each entry as four float64 RGB triples in [0, 1], or a ValueError naming the source, entry and key.

    Examples:
        >>> check_palette([{"grid_rgb1": [0.1, 0.2, 0.3]}])
        Traceback (most recent call last):
        ...
        ValueError: palette, entry 0: expected a dict with keys ('grid_rgb1', 'grid_rgb2', 'skybox_rgb', 'self_rgb'), got ['grid_rgb1'].
    """
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
