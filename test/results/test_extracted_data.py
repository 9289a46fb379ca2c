"""The published-results CSV files in ``vigen/results/data`` against the sources they came from.

``scripts/extract_published.py`` writes them from RL-ViGen's ``evaluation_score.xlsx`` and
DrQ-v2's ``curves/dmc_<task>.csv``. Here the sources are read again, independently of the
script, and every number in the CSV files is checked against them: each RL-ViGen value is the
workbook cell its ``where`` cites, every literal per-seed cell is cited once, and each DrQ-v2
mean, median and std is recomputed from the curves. The CSV files are read with the ``csv``
module only (``vigen.results`` is not imported). The sources sit outside the repository, in
``../shared/data``; the comparisons are skipped when they are absent.
"""

from __future__ import annotations

import csv
import math
import re
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
SHARED = REPO.parent / "shared" / "data"
DATA = REPO / "vigen" / "results" / "data"

SCHEMA = ["method", "variant", "source", "protocol", "suite", "task", "level", "statistic", "unit",
          "budget", "budget_unit", "seeds", "seed", "value", "spread", "spread_kind", "where"]
METHODS = {"drqv2", "drq", "curl", "svea", "srm", "sgqn", "pieg", "vrl3"}

# sheet -> (suite, unit, levels) as the schema asks for them.
SHEETS = {
    "Locomotion": ("loco", "return", {"easy", "hard"}),
    "Robosuite": ("robosuite", "return", {"easy", "medium", "hard"}),
    "Habitat": ("habitat", "success_percent", {"test"}),
    "Adroit": ("adroit", "success_percent", {"color_easy", "color_hard", "video_easy", "video_hard"}),
    "CARLA": ("carla", "return", {"easy", "medium", "hard"}),
    "Cross-embodiment": ("robosuite", "return", {"robot_iiwa", "robot_kinova3"}),
    "Camera-view": ("adroit", "success_percent", {"camera_easy", "camera_hard"}),
}
# Row labels of the task rows (column A, lower-cased) -> task; CARLA's task is its label lower-cased.
TASK_LABELS = {"unitree walk": "unitree-walk", "unitree stand": "unitree-stand", "door": "door", "lift": "lift",
               "twoarm": "two-arm-peg-in-hole", "pen": "pen", "hammer": "hammer"}
# Numbers in seed columns that are not scores: the header "drqv2(cross Kinova3)" carries seed labels 1..5.
SEED_LABEL_CELLS = {"Cross-embodiment": {"B6": 1, "C6": 2, "D6": 3, "E6": 4, "F6": 5}}
WHERE_XLSX = re.compile(r"^results/evaluation_score\.xlsx, sheet (?P<sheet>[^,]+), row (?P<row>\d+), "
                        r"cell (?P<cell>[A-Z]+\d+)(?:, block '[^']*')?(?:; values as printed; 0–0\.05 may be fractions)?$")

DMC_TASKS = {"walker_walk": "walker-walk", "walker_stand": "walker-stand", "cartpole_swingup": "cartpole-swingup",
             "cartpole_balance": "cartpole-balance", "cup_catch": "ball_in_cup-catch", "reacher_easy": "reacher-easy",
             "finger_spin": "finger-spin", "cheetah_run": "cheetah-run"}
WHERE_CURVE = re.compile(r"^curves/(?P<file>dmc_\w+\.csv), frame (?P<frame>\d+)$")


def shared(relative: str) -> Path:
    path = SHARED / relative
    if not path.exists():
        pytest.skip(f"../shared/data/{relative} not found: the published source files sit beside the "
                    "repository in the project's workspace")
    return path


def read_rows(name: str) -> tuple[list[str], list[dict[str, str]]]:
    with (DATA / name).open(newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        header = next(reader)
        lines = list(reader)
    assert all(len(line) == len(header) for line in lines), f"{name}: a row has the wrong number of fields"
    return header, [dict(zip(header, line)) for line in lines]


def is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@pytest.mark.parametrize("name", ["rlvigen.csv", "drqv2.csv"])
def test_header_is_the_schema(name):
    header, rows = read_rows(name)
    assert header == SCHEMA
    assert rows and all(row["method"] in METHODS and row["variant"] == "" for row in rows)
    assert all(row["source"] == row["protocol"] == name.removesuffix(".csv") for row in rows)


# ------------------------------------------------------------------------------------------ RL-ViGen


@pytest.fixture(scope="module")
def workbook():
    path = shared("rlvigen/evaluation_score.xlsx")
    openpyxl = pytest.importorskip("openpyxl", reason="openpyxl reads RL-ViGen's evaluation_score.xlsx")
    return openpyxl.load_workbook(path)  # formulas are kept as text, so literal numbers stand apart


def seed_columns(ws) -> dict[str, int]:
    """Column letter -> seed, from the seed1..seed5 headers of row 1."""
    columns = {cell.column_letter: int(cell.value[4:]) for cell in ws[1]
               if isinstance(cell.value, str) and re.fullmatch(r"seed\d+", cell.value.strip())}
    assert sorted(columns.values()) == [1, 2, 3, 4, 5], f"{ws.title}: row 1 headers"
    return columns


def test_rlvigen_values_equal_the_cells_they_cite(workbook):
    _, rows = read_rows("rlvigen.csv")
    for row in rows:
        match = WHERE_XLSX.match(row["where"])
        assert match, row["where"]
        ws = workbook[match["sheet"]]
        cell = ws[match["cell"]]
        suite, unit, levels = SHEETS[match["sheet"]]
        assert cell.row == int(match["row"]), row["where"]
        assert seed_columns(ws).get(cell.column_letter) == int(row["seed"]), f"{row['where']}: not seed{row['seed']}'s column"
        assert is_number(cell.value), f"{row['where']}: {cell.value!r} is not a literal number"
        assert float(row["value"]) == cell.value, row["where"]
        expected_text = str(cell.value) if isinstance(cell.value, int) else repr(float(cell.value))
        assert row["value"] == expected_text, f"{row['where']}: {row['value']!r} written for {cell.value!r}"
        label = str(ws.cell(row=cell.row, column=1).value).strip()
        if match["sheet"] == "Habitat":
            assert (row["method"], row["task"]) == (label, "imagenav"), row["where"]
        elif match["sheet"] == "CARLA":
            assert row["task"] == label.lower(), row["where"]
        else:
            assert row["task"] == TASK_LABELS[label.lower()], row["where"]
        assert (row["suite"], row["unit"], row["statistic"], row["seeds"]) == (suite, unit, "seed", "5")
        assert row["level"] in levels, row["where"]
        assert row["spread"] == row["spread_kind"] == "", row["where"]
        assert (row["budget"] == "") == (row["budget_unit"] == ""), row["where"]
        assert row["budget_unit"] in ("", "frames"), row["where"]


def test_rlvigen_cites_every_literal_per_seed_cell_once(workbook):
    _, rows = read_rows("rlvigen.csv")
    cited: dict[str, list[str]] = defaultdict(list)
    for row in rows:
        match = WHERE_XLSX.match(row["where"])
        assert match, row["where"]
        cited[match["sheet"]].append(match["cell"])
    assert set(cited) == set(workbook.sheetnames) == set(SHEETS)
    for ws in workbook.worksheets:
        columns = seed_columns(ws)
        literal = {cell.coordinate for line in ws.iter_rows(min_row=2) for cell in line
                   if cell.column_letter in columns and is_number(cell.value)}
        labels = SEED_LABEL_CELLS.get(ws.title, {})
        assert {coordinate: ws[coordinate].value for coordinate in labels} == labels
        literal -= set(labels)
        assert len(cited[ws.title]) == len(set(cited[ws.title])), f"{ws.title}: a cell is cited twice"
        assert len(cited[ws.title]) == len(literal), f"{ws.title}: {len(cited[ws.title])} rows, {len(literal)} cells"
        assert set(cited[ws.title]) == literal, ws.title


def test_rlvigen_every_setting_has_seeds_one_to_five():
    _, rows = read_rows("rlvigen.csv")
    seeds: dict[tuple[str, ...], list[int]] = defaultdict(list)
    for row in rows:
        seeds[row["method"], row["suite"], row["task"], row["level"]].append(int(row["seed"]))
    assert seeds
    for key, found in seeds.items():
        assert sorted(found) == [1, 2, 3, 4, 5], key


# -------------------------------------------------------------------------------------------- DrQ-v2


def test_drqv2_statistics_equal_the_curves():
    folder = shared("drqv2_curves")
    per_seed: dict[tuple[str, int], dict[int, float]] = defaultdict(dict)
    for path in sorted(folder.glob("dmc_*.csv")):
        with path.open(newline="") as f:
            for line in csv.DictReader(f):
                per_seed[path.name, int(line["frame"])][int(line["seed"])] = float(line["episode_reward"])
    assert per_seed, "no curves found"

    _, rows = read_rows("drqv2.csv")
    found: dict[tuple[str, int], dict[str, dict[str, str]]] = defaultdict(dict)
    for row in rows:
        match = WHERE_CURVE.match(row["where"])
        assert match, row["where"]
        key = (match["file"], int(match["frame"]))
        assert row["statistic"] not in found[key], f"{row['where']}: {row['statistic']} twice"
        found[key][row["statistic"]] = row
    assert set(found) == set(per_seed), "the (task, frame) pairs differ from the curves'"

    def close(text: str, expected: float) -> bool:
        return math.isclose(float(text), expected, rel_tol=1e-9, abs_tol=1e-12)

    for (name, frame), by_seed in per_seed.items():
        values = np.array([by_seed[seed] for seed in sorted(by_seed)])
        stats = found[name, frame]
        assert set(stats) == {"mean", "median"}, (name, frame)
        for row in stats.values():
            assert (row["suite"], row["task"], row["level"], row["unit"]) == (
                "dmc", DMC_TASKS[name[len("dmc_"):-len(".csv")]], "train", "return"), row["where"]
            assert (row["budget"], row["budget_unit"], row["seeds"], row["seed"]) == (
                str(frame), "frames", str(len(values)), ""), row["where"]
        mean, median = stats["mean"], stats["median"]
        assert close(mean["value"], float(np.mean(values))), mean["where"]
        assert close(mean["spread"], float(np.std(values, ddof=1))) and mean["spread_kind"] == "std", mean["where"]
        assert close(median["value"], float(np.median(values))), median["where"]
        assert median["spread"] == median["spread_kind"] == "", median["where"]
