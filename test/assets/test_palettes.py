"""DMC-GB palette files: every pickle protocol and torch.save format read, no code ever run, bad data named."""

from __future__ import annotations

import builtins
import os
import pickle
from pathlib import Path

import numpy as np
import pytest
import torch

from vigen.transforms import load_dmcgb_palette

DMCGB = Path(__file__).resolve().parents[3] / "shared" / "data" / "dmcgb"
KEYS = ("grid_rgb1", "grid_rgb2", "skybox_rgb", "self_rgb")
TORCH_LEGACY_HEADER = (0x1950A86A20F9469CFC6C, 1001)


def _entries(count: int = 3) -> list[dict[str, np.ndarray]]:
    rng = np.random.default_rng(0)
    entries = [{key: rng.uniform(0, 1, 3) for key in KEYS} for _ in range(count)]
    entries[0]["self_rgb"] = entries[0]["self_rgb"].astype(np.float32)  # DMC-GB mixes float widths
    entries[-1]["grid_rgb1"] = np.array([0.0, 1.0, 0.5])  # the ends of the range are valid
    return entries


def _assert_same(palette: list[dict[str, np.ndarray]], entries: list[dict[str, np.ndarray]]) -> None:
    assert len(palette) == len(entries)
    for loaded, written in zip(palette, entries):
        assert sorted(loaded) == sorted(KEYS)
        for key in KEYS:
            assert loaded[key].shape == (3,) and loaded[key].dtype == np.float64
            np.testing.assert_array_equal(loaded[key], np.asarray(written[key], dtype=np.float64))


def _write_pickle(path: Path, obj: object, protocol: int = 4) -> Path:
    with path.open("wb") as file:
        pickle.dump(obj, file, protocol=protocol)
    return path


def _write_torch(path: Path, obj: object) -> Path:
    torch.save(obj, path)
    return path


def _trusted_legacy_read(path: Path) -> list[dict[str, np.ndarray]]:
    """The reference reading of DMC-GB's own sample (trusted data): the 4th pickle of a legacy torch.save file."""
    with path.open("rb") as file:
        header = (pickle.load(file), pickle.load(file))
        assert header == TORCH_LEGACY_HEADER
        pickle.load(file)
        return pickle.load(file)


@pytest.mark.parametrize("protocol", range(pickle.HIGHEST_PROTOCOL + 1))
def test_every_pickle_protocol_loads_the_data(tmp_path, protocol):
    entries = _entries()
    path = _write_pickle(tmp_path / f"color_p{protocol}.pt", entries, protocol)
    _assert_same(load_dmcgb_palette(path), entries)


def test_protocol_5_out_of_line_layouts_and_lists(tmp_path):
    """Non-contiguous arrays and plain lists are colours too."""
    entries = [{key: np.linspace(0, 1, 6)[::2] for key in KEYS}, {key: [0.25, 0.5, 0.75] for key in KEYS}]
    _assert_same(load_dmcgb_palette(_write_pickle(tmp_path / "color.pt", entries, 5)), entries)


@pytest.mark.parametrize("zipfile", [True, False], ids=["torch-zip", "torch-legacy"])
def test_torch_save_files_still_load(tmp_path, zipfile):
    entries = _entries()
    torch.save(entries, tmp_path / "color.pt", _use_new_zipfile_serialization=zipfile)
    _assert_same(load_dmcgb_palette(tmp_path / "color.pt"), entries)
    as_tensors = [{key: torch.as_tensor(value, dtype=torch.float64) for key, value in entry.items()} for entry in entries]
    torch.save(as_tensors, tmp_path / "tensors.pt", _use_new_zipfile_serialization=zipfile)
    _assert_same(load_dmcgb_palette(tmp_path / "tensors.pt"), entries)


@pytest.mark.skipif(not DMCGB.is_dir(), reason="the DMC-GB sample in ../shared/data/dmcgb is absent (a user's clone)")
@pytest.mark.parametrize("name", ["color_easy.pt", "color_hard.pt"])
def test_real_dmcgb_palettes(name):
    reference = _trusted_legacy_read(DMCGB / name)
    palette = load_dmcgb_palette(DMCGB / name)
    assert len(palette) == 100
    _assert_same(palette, reference)
    offsets = [entry["grid_rgb2"] - entry["grid_rgb1"] for entry in palette if entry["grid_rgb2"].max() < 1]
    assert np.allclose(offsets, 0.1), "DMC-GB's second grid tone is the first plus 0.1"


class _System:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


class _Exec:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return builtins.exec, (f"open({str(self.marker)!r}, 'w').close()",)


class _OpenForWriting:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return builtins.open, (str(self.marker), "w")


def _legacy_torch_pickle(path: Path, obj: object) -> Path:
    """A file laid out as the legacy torch.save format, written with plain pickle (as an attacker would)."""
    with path.open("wb") as file:
        for part in (*TORCH_LEGACY_HEADER, {"protocol_version": 1001, "little_endian": True}, obj, []):
            pickle.dump(part, file, protocol=2)
    return path


WRITERS = {
    "pickle-p0": lambda path, obj: _write_pickle(path, obj, 0),
    "pickle-p2": lambda path, obj: _write_pickle(path, obj, 2),
    "pickle-p4": lambda path, obj: _write_pickle(path, obj, 4),
    "pickle-p5": lambda path, obj: _write_pickle(path, obj, 5),
    "torch-legacy-layout": _legacy_torch_pickle,
    "torch-zip": _write_torch,
}


@pytest.mark.parametrize("payload", [_System, _Exec, _OpenForWriting], ids=["os.system", "exec", "open"])
@pytest.mark.parametrize("writer", list(WRITERS))
def test_malicious_pickles_are_refused_and_never_run(tmp_path, payload, writer):
    marker = tmp_path / "marker"
    entry = {key: np.full(3, 0.5) for key in KEYS}
    entry["self_rgb"] = payload(marker)
    path = WRITERS[writer](tmp_path / "color_bad.pt", [entry])
    with pytest.raises(pickle.UnpicklingError) as caught:
        load_dmcgb_palette(path)
    message = str(caught.value)
    assert str(path) in message and "refuse" in message
    assert "weights_only=False" not in message, "the error must not invite turning the safety off"
    refused = {_System: "system", _Exec: "exec", _OpenForWriting: "open"}[payload]
    assert refused in message.replace(f"{path}", ""), f"the refused global is named: {message}"
    assert not marker.exists(), "the payload ran"


def test_codecs_encode_only_decodes_latin1_bytes(tmp_path):
    """Protocol 0–2 pickles store bytes through _codecs.encode; any other use of it is refused."""
    import _codecs

    class _Codec:
        def __reduce__(self):
            return _codecs.encode, (b"x", "zlib_codec")

    path = _write_pickle(tmp_path / "color.pt", [{key: _Codec() for key in KEYS}], 2)
    with pytest.raises(pickle.UnpicklingError, match="latin1"):
        load_dmcgb_palette(path)


@pytest.mark.parametrize("writer", ["pickle", "torch-legacy", "torch-zip"])
def test_empty_and_truncated_files_are_named(tmp_path, writer):
    empty = tmp_path / "color_empty.pt"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match=f"{empty}.*empty"):
        load_dmcgb_palette(empty)
    whole = tmp_path / "whole.pt"
    if writer == "pickle":
        _write_pickle(whole, _entries(), 2)
    else:
        torch.save(_entries(), whole, _use_new_zipfile_serialization=writer == "torch-zip")
    data = whole.read_bytes()
    for cut in (1, 5, len(data) // 3, len(data) // 2, len(data) - 20):
        truncated = tmp_path / f"color_cut{cut}.pt"
        truncated.write_bytes(data[:cut])
        with pytest.raises(ValueError, match=f"{truncated}.*(truncated|not a palette)"):
            load_dmcgb_palette(truncated)


def test_garbage_is_named(tmp_path):
    garbage = tmp_path / "color_garbage.pt"
    garbage.write_bytes(bytes(range(256)) * 4)
    with pytest.raises((ValueError, pickle.UnpicklingError), match=str(garbage)):
        load_dmcgb_palette(garbage)


BAD_VALUES = {
    "above one": (np.array([0.2, 1.5, 0.3]), "outside \\[0, 1\\]"),
    "negative": (np.array([-0.1, 0.5, 0.3]), "outside \\[0, 1\\]"),
    "0-255 scale": (np.array([12.0, 200.0, 30.0]), "outside \\[0, 1\\].*255"),
    "NaN": (np.array([0.2, np.nan, 0.3]), "non-finite"),
    "inf": (np.array([0.2, np.inf, 0.3]), "non-finite"),
    "two values": (np.array([0.2, 0.3]), "shape"),
    "six values": (np.full(6, 0.5), "shape"),
    "matrix": (np.full((3, 3), 0.5), "shape"),
    "text": ("red", "three numbers|shape"),
}


@pytest.mark.parametrize("writer", ["pickle", "torch-zip"])
@pytest.mark.parametrize("bad", list(BAD_VALUES))
def test_bad_values_are_rejected_naming_file_entry_and_key(tmp_path, writer, bad):
    value, problem = BAD_VALUES[bad]
    entries = _entries()
    entries[1]["skybox_rgb"] = value
    path = tmp_path / "color_bad.pt"
    (_write_pickle if writer == "pickle" else _write_torch)(path, entries)
    with pytest.raises(ValueError, match=f"{path}, entry 1, key 'skybox_rgb'.*({problem})"):
        load_dmcgb_palette(path)


@pytest.mark.parametrize("writer", ["pickle", "torch-zip"])
def test_wrong_structure_is_named(tmp_path, writer):
    write = _write_pickle if writer == "pickle" else _write_torch
    missing = _entries()
    del missing[2]["self_rgb"]
    with pytest.raises(ValueError, match=r"entry 2: expected a dict with keys"):
        load_dmcgb_palette(write(tmp_path / "missing.pt", missing))
    with pytest.raises(ValueError, match="non-empty list"):
        load_dmcgb_palette(write(tmp_path / "empty_list.pt", []))
    with pytest.raises(ValueError, match="non-empty list"):
        load_dmcgb_palette(write(tmp_path / "dict.pt", {"grid_rgb1": [0.1, 0.2, 0.3]}))



def test_palette_entries_given_in_code_are_checked_when_the_transform_is_built():
    """Entries with other keys raised KeyError 'grid_rgb1' at the first reset."""
    from vigen.transforms import RandomSceneColors

    with pytest.raises(ValueError, match=r"palette=\.\.\.\), entry 0: expected a dict with keys \('grid_rgb1'.*got \['grid'\]"):
        RandomSceneColors(palette=[{"grid": [0.1, 0.2, 0.3]}])
    entry = {key: [0.2, 0.4, 0.6] for key in ("grid_rgb1", "grid_rgb2", "skybox_rgb", "self_rgb")}
    with pytest.raises(ValueError, match=r"entry 1, key 'self_rgb'.*outside \[0, 1\]"):
        RandomSceneColors(palette=[entry, {**entry, "self_rgb": [0, 128, 255]}])
    assert RandomSceneColors(palette=[entry]).palette[0]["self_rgb"].tolist() == [0.2, 0.4, 0.6]
