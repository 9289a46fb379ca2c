"""The benchmarks' named data sets (:data:`DATASETS`) and the look-up by name."""

from __future__ import annotations

from pathlib import Path

from vigen.data.errors import UnknownDataSetError
from vigen.data.records import Archive, ArchiveLayout, DataSet, PinnedFile, read_pinned_files

DMCGB_COMMIT = "ff9c0aa8d47685ed972414c67f1b7225e37ff85e"
"""The DMC-GB commit whose ``src/env/data/`` the pinned video list was taken from."""

DMCGB_VIDEOS = DataSet(
    name="dmcgb-videos",
    title="DMC-GB's background videos: video_easy (10) and video_hard (100)",
    license="MIT (DMC-GB, Nicklas Hansen)",
    source=f"github.com/nicklashansen/dmcontrol-generalization-benchmark@{DMCGB_COMMIT}:src/env/data/",
    files=read_pinned_files(Path(__file__).with_name("dmcgb_videos.tsv")),
    url_template=(
        "https://raw.githubusercontent.com/nicklashansen/dmcontrol-generalization-benchmark/"
        f"{DMCGB_COMMIT}/src/env/data/{{path}}"
    ),
    notes=("DMC-GB2 (aalmuzairee/dmcgb2) holds the same blobs under envs/dmcgb/data/.",),
)

DAVIS2017 = DataSet(
    name="davis2017",
    title="DAVIS 2017 trainval, 480p JPEG frames (the RL-ViGen / DMC-GB2 video backgrounds)",
    license="DAVIS terms (davischallenge.org); cite Pont-Tuset et al. 2017 and Perazzi et al. 2016",
    source="data.vision.ee.ethz.ch (DAVIS challenge, ETH Zurich)",
    archive=Archive(
        file_name="DAVIS-2017-trainval-480p.zip",
        url="https://data.vision.ee.ethz.ch/csergi/share/davis/DAVIS-2017-trainval-480p.zip",
        layout=ArchiveLayout(
            top="DAVIS",
            required=("DAVIS/ImageSets/2017/train.txt", "DAVIS/ImageSets/2017/val.txt"),
            listings=("DAVIS/ImageSets/2017/train.txt", "DAVIS/ImageSets/2017/val.txt"),
            item_glob="DAVIS/JPEGImages/480p/{item}/*.jpg",
        ),
    ),
    notes=("The archive's sha256 is not pinned upstream: vigen records it (and every extracted file's) at the first fetch.",),
)

RESNET18_SHA256 = "f37072fd47e89c5e827621c5baffa7500819f7896bbacec160b1a16c560e07ec"
"""The sha256 of torchvision's ``resnet18-f37072fd.pth`` (its name carries the first 8 hex digits, which torchvision
checks on download); the full value as widely quoted for that file, with its size, 46,830,571 bytes."""

TORCHVISION_RESNET18 = DataSet(
    name="torchvision-resnet18",
    title="torchvision's ImageNet ResNet-18 weights (IMAGENET1K_V1), PIE-G's frozen encoder",
    license="BSD-3-Clause (torchvision); the weights were trained on ImageNet, whose terms restrict use to research",
    source="download.pytorch.org/models/ (torchvision.models.ResNet18_Weights.IMAGENET1K_V1)",
    files=(PinnedFile("resnet18-f37072fd.pth", None, 46_830_571, sha256=RESNET18_SHA256),),
    url_template="https://download.pytorch.org/models/{path}",
    notes=("A torchvision state dict: load it with vigen's PIEGEncoder(weights=...) or make_loss('pieg', ..., "
           "encoder_weights=...); examples/train.py --recipe pieg-rlvigen finds it here.",),
)

DATASETS: dict[str, DataSet] = {dataset.name: dataset for dataset in (DMCGB_VIDEOS, DAVIS2017, TORCHVISION_RESNET18)}
"""Every named data set, by name. A plain dict of :class:`~vigen.data.records.DataSet` records."""


def get_dataset(name: str | DataSet) -> DataSet:
    """The record of a data set by name (a record is returned as it is); an unknown name lists the known ones.

    Examples:
        >>> from vigen.data import get_dataset
        >>> videos = get_dataset("dmcgb-videos")
        >>> videos.parts, len(videos.files), len(videos.files_of("video_hard"))
        (('video_easy', 'video_hard'), 110, 100)
    """
    if isinstance(name, DataSet):
        return name
    try:
        return DATASETS[name]
    except KeyError:
        raise UnknownDataSetError(f"unknown data set {name!r}; known data sets: {', '.join(DATASETS)}.") from None
