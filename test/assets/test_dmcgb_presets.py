"""DMC-GB's colour presets ship with vigen as plain JSON: the same numbers as DMC-GB's files, their license, their provenance."""

from __future__ import annotations

import ast
import fnmatch
import hashlib
import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from vigen.assets import dmcgb_presets
from vigen.assets.palettes import DMCGB_PRESETS, PALETTE_KEYS, dmcgb_presets_record, load_dmcgb_palette

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data" / "dmcgb"
SHIPPED = ROOT / "vigen" / "assets" / "data" / "dmcgb_colors.json"
NO_SAMPLE = ("DMC-GB's color_{easy,hard}.pt are not at ../shared/data/dmcgb (a user's clone): nothing to compare the "
             "shipped values with")
DMCGB_COMMIT = "ff9c0aa8d47685ed972414c67f1b7225e37ff85e"
DMCGB2_COMMIT = "5fd8fd7a886319a4a6854b4f8c421f897a32e776"


def git_blob_id(data: bytes) -> str:
    """What ``git hash-object`` prints for a file holding ``data``."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


@pytest.mark.skipif(not SHARED.is_dir(), reason=NO_SAMPLE)
@pytest.mark.parametrize("name", DMCGB_PRESETS)
def test_shipped_values_equal_the_pickles_exactly(name):
    from_pickle = load_dmcgb_palette(SHARED / f"{name}.pt")
    shipped = dmcgb_presets(name)
    assert len(shipped) == len(from_pickle) == 100
    for index, (ours, theirs) in enumerate(zip(shipped, from_pickle)):
        for key in PALETTE_KEYS:
            # bit for bit: float64 bytes, not a tolerance
            assert ours[key].dtype == np.float64 and ours[key].tobytes() == theirs[key].astype(np.float64).tobytes(), (index, key)


@pytest.mark.skipif(not SHARED.is_dir(), reason=NO_SAMPLE)
@pytest.mark.parametrize("name", DMCGB_PRESETS)
def test_the_pickles_are_the_files_the_provenance_names(name):
    files = dmcgb_presets_record()["provenance"]["files"]
    assert git_blob_id((SHARED / f"{name}.pt").read_bytes()) == files[name]["git_blob"]


def test_provenance_and_license_notice():
    record = dmcgb_presets_record()
    provenance, license_ = record["provenance"], record["license"]
    assert provenance["repository"] == "https://github.com/nicklashansen/dmcontrol-generalization-benchmark"
    assert provenance["commit"] == DMCGB_COMMIT
    assert provenance["files"] == {
        "color_easy": {"path": "src/env/data/color_easy.pt", "git_blob": "49017e0089c32bce39d4e5c9c4a2beca85923be0"},
        "color_hard": {"path": "src/env/data/color_hard.pt", "git_blob": "f13f9f4a1d2200347ca682a0e5192f3987161f6c"},
    }
    also = provenance["also_in"]
    assert (also["repository"], also["commit"]) == ("https://github.com/aalmuzairee/dmcgb2", DMCGB2_COMMIT)
    assert also["files"] == {"color_easy": "envs/dmcgb/data/color_easy.pt", "color_hard": "envs/dmcgb/data/color_hard.pt"}
    # MIT asks that the copyright notice and the permission notice go with the values
    assert license_["name"] == "MIT" and license_["copyright"] == "Copyright (c) 2020 Nicklas Hansen"
    assert license_["copyright"] in license_["text"]
    assert "The above copyright notice and this permission notice shall be included in all" in license_["text"]


def test_the_file_is_plain_json_whose_floats_read_back_exactly():
    text = SHIPPED.read_text(encoding="utf-8")
    data = json.loads(text)  # JSON: reading it runs no code
    assert data["keys"] == list(PALETTE_KEYS) and set(data["presets"]) == set(DMCGB_PRESETS)
    for name in DMCGB_PRESETS:
        for entry in data["presets"][name]:
            for key in PALETTE_KEYS:
                assert len(entry[key]) == 3 and all(type(v) is float for v in entry[key])
                for value in entry[key]:  # each number is written as repr(float): the shortest text of that float64
                    assert repr(value) in text
    with pytest.raises(pickle.UnpicklingError):
        pickle.loads(SHIPPED.read_bytes())  # not a pickle in disguise


def test_setup_ships_the_file_as_package_data():
    tree = ast.parse((ROOT / "setup.py").read_text())
    package_data = next(ast.literal_eval(k.value) for node in ast.walk(tree) if isinstance(node, ast.Call)
                        for k in node.keywords if k.arg == "package_data")
    relative = SHIPPED.relative_to(ROOT / "vigen" / "assets").as_posix()
    assert any(fnmatch.fnmatch(relative, pattern) for pattern in package_data.get("vigen.assets", []))


def test_each_call_returns_fresh_arrays_and_unknown_names_say_which_exist():
    first = dmcgb_presets("color_easy")
    first[0]["self_rgb"][:] = 0
    assert dmcgb_presets("color_easy")[0]["self_rgb"].any()
    with pytest.raises(ValueError, match=r"Unknown DMC-GB preset list 'color_medium'.*'color_easy' and 'color_hard'"):
        dmcgb_presets("color_medium")
