"""Files pinned by sha256 (served outside a git repository: torchvision's weights): fetched from their URL, checked, found.

The tests serve a made-up weights file from 127.0.0.1 and inject its pin; the machines that test vigen cannot reach
download.pytorch.org."""

from __future__ import annotations

import hashlib

import pytest

from vigen.datasets import DATASETS, CorruptFileError, DataSet, FetchError, PinnedFile, fetch, locate, verify
from vigen.datasets.__main__ import main

WEIGHTS = bytes(range(256)) * 64  # a made-up "resnet18-xxxxxxxx.pth"


def weights_dataset(url: str, data: bytes = WEIGHTS, name: str = "weights") -> DataSet:
    sha256 = hashlib.sha256(data).hexdigest()  # computed here on its own, not through vigen.datasets
    return DataSet(name, "a made-up weights file", license="CC0", source="this test",
                   files=(PinnedFile(f"resnet18-{sha256[:8]}.pth", None, len(data), sha256=sha256),),
                   url_template=f"{url}/models/{{path}}")


def test_a_file_pinned_by_sha256_is_fetched_from_its_url_checked_and_found(server, isolated_cache):
    dataset = weights_dataset(server.url)
    pinned = dataset.files[0]
    (server.folder / "models").mkdir()
    (server.folder / "models" / pinned.path).write_bytes(WEIGHTS)
    assert fetch(dataset) == isolated_cache / "weights"
    assert server.requests == [(f"/models/{pinned.path}", None)], "straight from its URL template (no mirror)"
    assert (isolated_cache / "weights" / pinned.path).read_bytes() == WEIGHTS
    assert locate(dataset) == isolated_cache / "weights"
    report = verify(dataset)
    assert report.ok and report.checked == (pinned.path,)
    (isolated_cache / "weights" / pinned.path).write_bytes(WEIGHTS[::-1])  # same size, other content
    (bad,) = verify(dataset).mismatched
    assert bad.expected == f"sha256 {pinned.sha256} ({len(WEIGHTS)} bytes)" and bad.got.startswith("sha256 ")


def test_other_bytes_under_the_pinned_name_are_refused_and_not_kept(server, isolated_cache):
    dataset = weights_dataset(server.url)
    pinned = dataset.files[0]
    (server.folder / "models").mkdir()
    (server.folder / "models" / pinned.path).write_bytes(WEIGHTS)
    server.faults[f"/models/{pinned.path}"] = "wrong"
    with pytest.raises(FetchError) as caught:
        fetch(dataset)
    (error,) = caught.value.failures
    assert isinstance(error, CorruptFileError) and f"expected sha256 {pinned.sha256}" in str(error)
    assert error.got == f"sha256 {hashlib.sha256(bytes(byte ^ 0xFF for byte in WEIGHTS)).hexdigest()}"
    assert not (isolated_cache / "weights" / pinned.path).exists() and locate(dataset) is None
    assert sorted(p.name for p in (isolated_cache / "weights").iterdir()) == [".fetch.lock"], "no .part, no pooch temporary"


def test_a_stale_part_of_a_sha256_pinned_file_is_downloaded_whole_once_more(server, isolated_cache):
    """pooch checks the sha256 of what the resumed download gave; it fails, and the file comes whole from byte 0."""
    dataset = weights_dataset(server.url)
    pinned = dataset.files[0]
    (server.folder / "models").mkdir()
    (server.folder / "models" / pinned.path).write_bytes(WEIGHTS)
    (isolated_cache / "weights").mkdir(parents=True)
    (isolated_cache / "weights" / (pinned.path + ".part")).write_bytes(WEIGHTS[::-1][:1000])
    events = []
    assert fetch(dataset, progress=events.append) == isolated_cache / "weights"
    assert (isolated_cache / "weights" / pinned.path).read_bytes() == WEIGHTS
    assert [header for _, header in server.requests] == ["bytes=1000-", None]
    assert [event.stage for event in events if event.stage in ("restart", "done", "failed")] == ["restart", "done"]


def test_torchvisions_resnet18_is_pinned_by_its_sha256_whose_prefix_its_name_carries():
    """torchvision names its files <arch>-<first 8 hex of the sha256>.pth and checks that prefix on download."""
    (pinned,) = DATASETS["torchvision-resnet18"].files
    assert pinned.path == "resnet18-f37072fd.pth" and pinned.sha256.startswith("f37072fd") and pinned.git_blob is None
    assert pinned.size == 46_830_571 and DATASETS["torchvision-resnet18"].url_of(pinned) == \
        "https://download.pytorch.org/models/resnet18-f37072fd.pth"
    assert main(["path", "torchvision-resnet18"]) == 1, "not fetched in this test's cache"


def test_a_pin_names_one_id():
    with pytest.raises(ValueError, match="pin it by a git blob id or by a sha256, one of them"):
        PinnedFile("a.pth", None, 1)
    with pytest.raises(ValueError, match="sha256 must be 64 lowercase hex digits"):
        PinnedFile("a.pth", None, 1, sha256="f37072fd")
