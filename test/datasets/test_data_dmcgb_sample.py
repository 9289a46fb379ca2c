"""DMC-GB's real sample videos (``../shared/data/dmcgb``) served as a mirror, checked against the shipped pinned blob ids."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from vigen.datasets import DownloadError, FetchError, fetch, get_dataset, locate, status, verify

SAMPLE = Path(__file__).parents[2] / ".." / "shared" / "data" / "dmcgb"
SAMPLE_FILES = ["video_easy/video0.mp4", "video_easy/video1.mp4", "video_hard/video0.mp4", "video_hard/video1.mp4",
                "video_hard/video2.mp4"]

pytestmark = pytest.mark.skipif(not (SAMPLE / "video_hard").is_dir(),
                                reason=f"DMC-GB's sample videos are not at {SAMPLE} (the shared data folder beside the project)")


def test_the_pinned_list_matches_the_shared_tree_listing():
    rows = [line.split("\t") for line in (SAMPLE / "TREE.tsv").read_text().splitlines()[2:]]
    videos = {path.removeprefix("src/env/data/"): (blob, size) for blob, size, path in rows if "/video_" in path}
    shipped = {f.path: (f.git_blob, "?" if f.size is None else str(f.size)) for f in get_dataset("dmcgb-videos").files}
    assert shipped == videos and len(shipped) == 110


def test_the_real_sample_videos_fetch_and_check_against_the_pinned_blob_ids(server, isolated_cache):
    (server.folder / "dmcgb-videos").symlink_to(SAMPLE.resolve())
    with pytest.raises(FetchError) as caught:
        fetch("dmcgb-videos", part="video_hard", mirror=server.url)
    missing = [error for error in caught.value.failures if isinstance(error, DownloadError) and error.reason == "missing"]
    assert len(missing) == len(caught.value.failures) == 97  # the sample holds video0-2 of video_hard's 100
    assert "  - video_hard/video99.mp4: dmcgb-videos/video_hard/video99.mp4 is not at" in str(caught.value)
    with pytest.raises(FetchError):
        fetch("dmcgb-videos", part="video_easy", mirror=server.url)
    report = verify("dmcgb-videos")
    assert report.ok and sorted(report.checked) == SAMPLE_FILES and len(report.absent) == 105
    assert [(s.part, s.present) for s in status("dmcgb-videos")] == [("video_easy", 2), ("video_hard", 3)]
    assert locate("dmcgb-videos", "video_hard") is None
    for relative in SAMPLE_FILES:  # and the ids agree with git itself
        blob = subprocess.run(["git", "hash-object", str(isolated_cache / "dmcgb-videos" / relative)], capture_output=True,
                              text=True, check=True).stdout.strip()
        assert blob == next(f.git_blob for f in get_dataset("dmcgb-videos").files if f.path == relative)
