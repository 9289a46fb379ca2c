"""DAVIS 2017's train and val splits as lists of frame folders (the Distracting Control Suite's background videos).

The Distracting Control Suite plays DAVIS 2017 videos of the ``train`` split, the first ``N`` of
them at low intensities: ``suite.load`` defaults ``background_dataset_videos="train"``
(DMC-GB's copy, ``src/env/distracting_control/suite.py:45``), and ``background.py`` turns
``"train"`` / ``"val"`` into DAVIS 2017's split lists, in name order, joins them to the dataset
path (DMC-GB passes ``<root>/DAVIS/JPEGImages/480p``, ``src/env/wrappers.py:32``) and keeps the
first ``num_videos`` (``background.py:119-143``). vigen reads the split from the dataset's own
list, ``ImageSets/2017/<split>.txt``, sorted by name as DCS's lists are.
"""

from __future__ import annotations

import os
from pathlib import Path

DAVIS_SPLITS = ("train", "val")
DAVIS_SPLIT_LISTS = Path("ImageSets") / "2017"
DAVIS_FRAMES = Path("JPEGImages") / "480p"
DAVIS_LAYOUT = ("DAVIS/ImageSets/2017/train.txt (and val.txt), one video name a line, and "
                "DAVIS/JPEGImages/480p/<video>/00000.jpg ... (the DAVIS 2017 TrainVal 480p download)")


def davis_split_folders(folder: str | os.PathLike, split: str) -> list[Path]:
    """The frame folders of DAVIS 2017's ``split`` (``"train"`` or ``"val"``), in name order, as DCS lists them.

    ``folder`` is the DAVIS root (holding ``ImageSets/`` and ``JPEGImages/``) or its frame folder
    ``JPEGImages/480p`` (what DMC-GB's DCS takes), whose split lists sit two levels up. A missing
    split list, or a listed video without its frame folder, raises a ``FileNotFoundError`` that
    names the expected layout.

    Examples:
        >>> import tempfile
        >>> root = Path(tempfile.mkdtemp()) / "DAVIS"
        >>> (root / "ImageSets" / "2017").mkdir(parents=True)
        >>> _ = (root / "ImageSets" / "2017" / "train.txt").write_text("boat\\nbear\\n")
        >>> for name in ("bear", "boat", "blackswan"):
        ...     (root / "JPEGImages" / "480p" / name).mkdir(parents=True)
        >>> [p.name for p in davis_split_folders(root, "train")]
        ['bear', 'boat']
        >>> [p.name for p in davis_split_folders(root / "JPEGImages" / "480p", "train")]
        ['bear', 'boat']
    """
    if split not in DAVIS_SPLITS:
        raise ValueError(f"DAVIS 2017 has the splits {DAVIS_SPLITS}, got split={split!r}.")
    folder = Path(folder).expanduser()
    if (folder / DAVIS_SPLIT_LISTS).is_dir():
        lists, frames = folder / DAVIS_SPLIT_LISTS, folder / DAVIS_FRAMES
    else:  # a frame folder JPEGImages/<resolution>
        lists, frames = folder.parent.parent / DAVIS_SPLIT_LISTS, folder
    split_list = lists / f"{split}.txt"
    if not split_list.is_file():
        raise FileNotFoundError(
            f"The Distracting Control Suite plays DAVIS 2017's {split!r} videos, listed in ImageSets/2017/{split}.txt, but "
            f"{split_list} does not exist (looked beside and two levels above {folder}). Expected layout: {DAVIS_LAYOUT}. "
            "Pass the DAVIS folder or its JPEGImages/480p folder, or split=None (level_options={'split': None}) to play "
            "every video under the folder in name order."
        )
    names = sorted({line.strip() for line in split_list.read_text().splitlines() if line.strip()})
    if not names:
        raise FileNotFoundError(f"{split_list} lists no videos; it should hold one DAVIS video name a line ({DAVIS_LAYOUT}).")
    missing = [name for name in names if not (frames / name).is_dir()]
    if missing:
        shown = ", ".join(missing[:5]) + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
        raise FileNotFoundError(
            f"{split_list} lists {len(names)} videos but {len(missing)} have no frame folder under {frames}: {shown}. "
            f"Expected layout: {DAVIS_LAYOUT}."
        )
    return [frames / name for name in names]
