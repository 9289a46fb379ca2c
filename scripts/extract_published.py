"""Turn two published result sources into the CSV files of ``vigen.results`` (one file per source).

    python scripts/extract_published.py                       # ../shared/data -> vigen/results/data
    python scripts/extract_published.py --overwrite           # replace files that already exist
    python scripts/extract_published.py --shared DIR --out DIR

openpyxl is needed for the RL-ViGen workbook (``pip install --target /tmp/oxl openpyxl`` and
``PYTHONPATH=/tmp/oxl`` is enough). ``test/results/test_extracted_data.py`` re-reads both sources
and checks the CSV files against them.

Sources (both MIT licensed, read only):

* ``rlvigen/evaluation_score.xlsx`` = gemcollector/RL-ViGen ``results/evaluation_score.xlsx``
  (byte-identical to master 90d8b8c; last changed there in 3c39f6b, 2024-04-05). Per-seed
  zero-shot scores. Only the literal numbers under the ``seed1`` … ``seed5`` headers of row 1
  (columns B–F) are kept; the =AVERAGE / =STDEV formula cells and the average column are not.
* ``drqv2_curves/dmc_<task>.csv`` = facebookresearch/drqv2 ``curves/``. One row per (seed, frame);
  ``frame`` counts environment frames (action repeat 2); evaluations every 20,000 frames from 0
  to 980,000 (walker_walk to 1,000,000; cheetah_run and reacher_easy to 2,980,000), 8–10 seeds,
  every seed present at every frame. Written here as the seed mean (with the sample std, ddof 1)
  and the seed median at each frame.

Layout of the workbook, sheet by sheet (as found, every row and column inspected):

* Locomotion, Robosuite, Adroit, Cross-embodiment, Camera-view: blocks. A header cell in column A
  names the method and the setting, e.g. ``DrQ-v2 (Easy)``, ``DrQ-v2 (Meidum)`` (sic, = medium),
  ``CURL(Easy)``, ``PIE-G (Color-Easy)``, ``drqv2(cross IIWA)``; then one row per task with the
  five seeds; then a formula row. Task labels: ``unitree walk``/``unitree stand``;
  ``door``/``lift``/``twoarm`` (= TwoArmPegInHole); ``Door``/``Pen``/``Hammer``.
* Habitat: one row per method (``drqv2``, ``svea``, …), one task (ImageNav), no blocks.
* CARLA: a block per method (header ``DrQ-v2``, ``CURL``, … without a setting); rows are weather
  conditions, and each pair is followed by a label row ``easy`` / ``medium`` / ``hard`` whose
  formula (``=AVERAGE(Gi:Gj)``) names exactly the condition rows it averages. That formula is how a
  condition gets its level here (easy: custom_soft_noisy_low_light, custom_soft_high_light;
  medium: HardRainSunset, SoftRainSunset; hard: custom_hard_low_light,
  custom_hard_noisy_low_light). The task is the condition name lower-cased. The sheet's used
  range reads A1:N116, but columns H–N hold nothing (one empty formatted cell, N87): there is no
  scene-structure part in this workbook, so no ``scene_structure`` level is written.

Oddities kept as they are (also printed by the script): the ``Meidum`` typo; ``drqv2(cross
Kinova3)`` (Cross-embodiment row 6) carries the seed numbers 1–5 as numbers in B6:F6 (labels,
not scores; not extracted); CARLA's DrQ hard rows hold literal averages (G44 = 23, G45 = 23.6)
where the other rows have =AVERAGE formulas (not a seed column; not extracted); Adroit's VRL3
colour-easy, colour-hard and video-easy blocks print Pen as 0.01–0.05 where every other block
prints whole percents, so those rows get the ``where`` note "values as printed; 0–0.05 may be
fractions"; identical blocks (e.g. Adroit's CURL color-easy and video-easy) are reported.

Training budget (``budget``, ``budget_unit``) of the RL-ViGen rows: left EMPTY for every sheet.
Each suite has two statements in gemcollector/RL-ViGen that disagree, and neither the workbook
nor the README says which run produced the scores:

* the Hydra task configs (master 90d8b8c): ``cfgs/task/easy.yaml:1`` num_train_frames 1100000,
  ``cfgs/task/medium.yaml:1`` 3100000, ``cfgs/task/hard.yaml:1`` 30100000; line 2 of
  ``cfgs/task/unitree_walk.yaml`` / ``unitree_stand.yaml`` / ``Lift.yaml`` /
  ``TwoArmPegInHole.yaml`` selects medium (3,100,000), of ``Door.yaml`` / ``carla.yaml`` /
  ``habitat.yaml`` easy (1,100,000); branch ViGen-adroit (353b4a9)
  ``src/cfgs_adroit/task/{door,hammer,pen}.yaml:1`` 4100000;
* the launch scripts, whose ``num_train_frames=${frames}`` overrides those defaults:
  ``scripts/train.sh:28-29`` unitree_walk 1001000 (lines 1-2, commented: unitree_stand 1001000),
  ``scripts/carlatrain.sh:1-2`` carla 1001000, ``scripts/habitrain.sh:1-2`` habitat 701000
  (its comment also lists TwoArmPegInHole Door Lift), ViGen-adroit ``src/train.sh:5`` 1001000.

To fill them once settled, put frames per (suite, level-group) into ``RLVIGEN_BUDGET_FRAMES``.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import io
import os
import re
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEFAULT_SHARED = REPO.parent / "shared" / "data"
DEFAULT_OUT = REPO / "vigen" / "results" / "data"

SCHEMA = ["method", "variant", "source", "protocol", "suite", "task", "level", "statistic", "unit",
          "budget", "budget_unit", "seeds", "seed", "value", "spread", "spread_kind", "where"]

# Every spelling in the sources, reduced to lower-case letters and digits, -> vigen's name.
METHODS = {"drqv2": "drqv2", "drq": "drq", "curl": "curl", "svea": "svea", "srm": "srm",
           "sgqn": "sgqn", "pieg": "pieg", "vrl3": "vrl3"}

XLSX_NAME = "results/evaluation_score.xlsx"  # its path in gemcollector/RL-ViGen, used in `where`
FRACTION_NOTE = "values as printed; 0–0.05 may be fractions"

# Frames of training behind the RL-ViGen scores, keyed by sheet name; empty on purpose (see above).
RLVIGEN_BUDGET_FRAMES: dict[str, int] = {}

ROBOSUITE_TASKS = {"door": "door", "lift": "lift", "twoarm": "two-arm-peg-in-hole"}
ADROIT_TASKS = {"door": "door", "hammer": "hammer", "pen": "pen"}


@dataclass(frozen=True)
class SheetSpec:
    suite: str
    unit: str
    layout: str  # "blocks", "methods" (Habitat) or "conditions" (CARLA)
    tasks: dict[str, str] = field(default_factory=dict)  # row label (lower-case) -> vigen task
    levels: dict[str, str] = field(default_factory=dict)  # header setting (lower-case) -> level


SHEETS = {
    "Locomotion": SheetSpec("loco", "return", "blocks",
                            {"unitree walk": "unitree-walk", "unitree stand": "unitree-stand"},
                            {"easy": "easy", "hard": "hard"}),
    "Robosuite": SheetSpec("robosuite", "return", "blocks", ROBOSUITE_TASKS,
                           {"easy": "easy", "medium": "medium", "meidum": "medium", "hard": "hard"}),
    "Habitat": SheetSpec("habitat", "success_percent", "methods", {"": "imagenav"}, {"": "test"}),
    "Adroit": SheetSpec("adroit", "success_percent", "blocks", ADROIT_TASKS,
                        {"color-easy": "color_easy", "color-hard": "color_hard",
                         "video-easy": "video_easy", "video-hard": "video_hard"}),
    "CARLA": SheetSpec("carla", "return", "conditions", {}, {"easy": "easy", "medium": "medium", "hard": "hard"}),
    "Cross-embodiment": SheetSpec("robosuite", "return", "blocks", ROBOSUITE_TASKS,
                                  {"cross iiwa": "robot_iiwa", "cross kinova3": "robot_kinova3"}),
    "Camera-view": SheetSpec("adroit", "success_percent", "blocks", ADROIT_TASKS,
                             {"easy": "camera_easy", "hard": "camera_hard"}),
}

DMC_TASKS = {  # curves file stem -> dm_control domain-task
    "walker_walk": "walker-walk", "walker_stand": "walker-stand", "cartpole_swingup": "cartpole-swingup",
    "cartpole_balance": "cartpole-balance", "cup_catch": "ball_in_cup-catch", "reacher_easy": "reacher-easy",
    "finger_spin": "finger-spin", "cheetah_run": "cheetah-run",
}

HEADER = re.compile(r"^(?P<method>[^()]+?)\s*(?:\((?P<setting>[^()]*)\))?$")
LEVEL_FORMULA = re.compile(r"^=AVERAGE\(G(\d+):G(\d+)\)$")


class SourceError(ValueError):
    """The source does not look the way this script expects; fix the script, not the data."""


def method_name(text: str) -> str:
    key = re.sub(r"[^a-z0-9]", "", text.lower())
    if key not in METHODS:
        raise SourceError(f"unknown method spelling {text!r}")
    return METHODS[key]


def number_text(value) -> str:
    """An int as written (``76``), a float with a round-trip exact repr (``0.01``)."""
    if isinstance(value, bool):
        raise SourceError(f"boolean where a number was expected: {value!r}")
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def is_formula(value) -> bool:
    return isinstance(value, str) and value.startswith("=")


# ----------------------------------------------------------------------------------------- RL-ViGen


def seed_columns(ws) -> dict[int, int]:
    """Column index (1-based) -> seed number, from the ``seed1`` … ``seed5`` headers of row 1."""
    columns = {}
    for cell in ws[1]:
        match = re.fullmatch(r"seed(\d+)", str(cell.value).strip()) if isinstance(cell.value, str) else None
        if match:
            columns[cell.column] = int(match.group(1))
    if sorted(columns.values()) != [1, 2, 3, 4, 5]:
        raise SourceError(f"sheet {ws.title}: row 1 seed headers are {sorted(columns.values())}, not seed1..seed5")
    return columns


def parse_header(sheet: str, spec: SheetSpec, text: str, row: int) -> tuple[str, str | None]:
    match = HEADER.match(text.strip())
    if not match:
        raise SourceError(f"sheet {sheet} row {row}: cannot read block header {text!r}")
    method = method_name(match.group("method"))
    setting = match.group("setting")
    if spec.layout == "conditions":
        if setting is not None:
            raise SourceError(f"sheet {sheet} row {row}: unexpected setting in CARLA header {text!r}")
        return method, None
    if setting is None or setting.strip().lower() not in spec.levels:
        raise SourceError(f"sheet {sheet} row {row}: unknown setting in block header {text!r}")
    return method, spec.levels[setting.strip().lower()]


def read_sheet(ws, notes: list[str]) -> list[dict]:
    """One record per literal per-seed score of a sheet, with its cell coordinates."""
    sheet = ws.title
    spec = SHEETS[sheet]
    seeds = seed_columns(ws)
    records: list[dict] = []
    method = level = header = None
    pending: list[dict] = []  # CARLA condition rows waiting for their level label row

    for row in ws.iter_rows(min_row=1):
        r = row[0].row
        label = row[0].value
        by_column = {cell.column: cell for cell in row}
        values = {col: by_column[col].value if col in by_column else None for col in seeds}
        numbers = {col: v for col, v in values.items() if is_number(v)}
        for cell in row:  # literal numbers outside the seed columns are not scores; say so
            if cell.column != 1 and cell.column not in seeds and is_number(cell.value):
                notes.append(f"{sheet} {cell.coordinate}: literal {cell.value!r} in a non-seed column (not extracted)")

        if r == 1 and label is None:
            continue
        if label is None:
            if numbers:
                raise SourceError(f"sheet {sheet} row {r}: numbers without a row label")
            continue
        if not isinstance(label, str):
            raise SourceError(f"sheet {sheet} row {r}: non-text label {label!r}")
        key = label.strip().lower()

        if spec.layout == "conditions" and key in spec.levels and not numbers:
            match = LEVEL_FORMULA.match(str(values[min(seeds)]))
            if not match:
                raise SourceError(f"sheet {sheet} row {r}: level row {label!r} without =AVERAGE(Gi:Gj)")
            covered = set(range(int(match.group(1)), int(match.group(2)) + 1))
            if covered != {p["row"] for p in pending} or not pending:
                raise SourceError(f"sheet {sheet} row {r}: {label!r} averages rows {sorted(covered)}, "
                                  f"but the condition rows above are {[p['row'] for p in pending]}")
            for p in pending:
                p["level"] = spec.levels[key]
            records.extend(pending)
            pending = []
            continue

        is_data = (spec.layout == "methods" and r > 1) or key in spec.tasks or (
            spec.layout == "conditions" and bool(numbers))
        if not is_data:  # a block header
            if pending:
                raise SourceError(f"sheet {sheet} row {r}: condition rows {[p['row'] for p in pending]} have no level row")
            method, level = parse_header(sheet, spec, label, r)
            header = label
            if numbers:
                if numbers == seeds:  # column -> the seed number the row-1 header gives that column
                    notes.append(f"{sheet} row {r}: header {label!r} carries the seed numbers 1-5 as numbers "
                                 f"in its seed cells (labels, not scores; not extracted)")
                else:
                    raise SourceError(f"sheet {sheet} row {r}: numbers on block header {label!r}")
            continue

        if spec.layout == "methods":
            row_method, task, row_level, row_header = method_name(label), spec.tasks[""], spec.levels[""], None
        elif spec.layout == "conditions":
            if method is None:
                raise SourceError(f"sheet {sheet} row {r}: condition row before any method header")
            row_method, task, row_level, row_header = method, key, None, header
        else:
            if method is None:
                raise SourceError(f"sheet {sheet} row {r}: task row before any block header")
            row_method, task, row_level, row_header = method, spec.tasks[key], level, header
        for col, seed in sorted(seeds.items(), key=lambda item: item[1]):
            value = values[col]
            if not is_number(value):
                raise SourceError(f"sheet {sheet} row {r}: seed{seed} is {value!r}, not a literal number")
            record = {"sheet": sheet, "row": r, "cell": f"{by_column[col].column_letter}{r}", "header": row_header,
                      "method": row_method, "task": task, "level": row_level, "seed": seed, "value": value}
            (pending if spec.layout == "conditions" else records).append(record)

    if pending:
        raise SourceError(f"sheet {sheet}: condition rows {[p['row'] for p in pending]} have no level row")
    return records


def audit(records: list[dict], notes: list[str]) -> None:
    """Report identical blocks and non-integer scores: things a reader of the CSV should know."""
    blocks: dict[tuple, dict] = {}
    for rec in records:
        blocks.setdefault((rec["sheet"], rec["method"], rec["level"]), {})[(rec["task"], rec["seed"])] = rec["value"]
    seen: dict[tuple, tuple] = {}
    for key, block in blocks.items():
        signature = (key[0], tuple(sorted(block.items())))
        if signature in seen:
            notes.append(f"{key[0]}: block {key[1]}/{key[2]} has exactly the same per-seed values as "
                         f"{seen[signature][1]}/{seen[signature][2]}")
        else:
            seen[signature] = key
    for key, block in blocks.items():
        if any(isinstance(v, float) and not float(v).is_integer() for v in block.values()):
            notes.append(f"{key[0]}: block {key[1]}/{key[2]} has non-integer scores "
                         f"{sorted({v for v in block.values() if not float(v).is_integer()})}")


def rlvigen_rows(xlsx: Path, notes: list[str]) -> tuple[list[dict], dict[str, int]]:
    import openpyxl  # only this source needs it

    workbook = openpyxl.load_workbook(xlsx)  # formulas stay text, so literals and formulas are told apart
    if set(workbook.sheetnames) != set(SHEETS):
        raise SourceError(f"sheets are {workbook.sheetnames}, expected {sorted(SHEETS)}")
    records = []
    for ws in workbook.worksheets:
        records.extend(read_sheet(ws, notes))
    audit(records, notes)

    fraction_blocks = {(rec["sheet"], rec["method"], rec["level"]) for rec in records
                       if SHEETS[rec["sheet"]].unit == "success_percent" and 0 < rec["value"] <= 0.05}
    counts: dict[str, int] = {}
    rows = []
    for rec in records:
        spec = SHEETS[rec["sheet"]]
        where = f"{XLSX_NAME}, sheet {rec['sheet']}, row {rec['row']}, cell {rec['cell']}"
        if rec["header"] is not None:
            where += f", block '{rec['header']}'"
        if (rec["sheet"], rec["method"], rec["level"]) in fraction_blocks:
            where += f"; {FRACTION_NOTE}"
        budget = RLVIGEN_BUDGET_FRAMES.get(rec["sheet"])
        rows.append({
            "method": rec["method"], "variant": "", "source": "rlvigen", "protocol": "rlvigen",
            "suite": spec.suite, "task": rec["task"], "level": rec["level"], "statistic": "seed",
            "unit": spec.unit, "budget": "" if budget is None else str(budget),
            "budget_unit": "" if budget is None else "frames", "seeds": "5", "seed": str(rec["seed"]),
            "value": number_text(rec["value"]), "spread": "", "spread_kind": "", "where": where,
        })
        counts[rec["sheet"]] = counts.get(rec["sheet"], 0) + 1
    return rows, counts


# ------------------------------------------------------------------------------------------- DrQ-v2


def drqv2_rows(folder: Path) -> tuple[list[dict], dict[str, int]]:
    files = sorted(folder.glob("dmc_*.csv"))
    if not files:
        raise SourceError(f"no dmc_*.csv in {folder}")
    rows, counts = [], {}
    for path in files:
        stem = path.stem[len("dmc_"):]
        if stem not in DMC_TASKS:
            raise SourceError(f"{path.name}: unknown task {stem!r}; add it to DMC_TASKS")
        by_frame: dict[int, dict[int, float]] = {}
        with path.open(newline="") as f:
            reader = csv.DictReader(f)
            if reader.fieldnames != ["", "agent", "task", "seed", "frame", "episode_reward", "hour"]:
                raise SourceError(f"{path.name}: columns {reader.fieldnames}")
            for line in reader:
                if line["agent"] != "DrQ-v2" or line["task"] != stem:
                    raise SourceError(f"{path.name}: row {line['']} is {line['agent']}/{line['task']}")
                frame, seed = int(line["frame"]), int(line["seed"])
                if seed in by_frame.setdefault(frame, {}):
                    raise SourceError(f"{path.name}: seed {seed} twice at frame {frame}")
                by_frame[frame][seed] = float(line["episode_reward"])
        for frame, per_seed in sorted(by_frame.items()):
            values = np.array([per_seed[s] for s in sorted(per_seed)], dtype=np.float64)
            common = {"method": "drqv2", "variant": "", "source": "drqv2", "protocol": "drqv2", "suite": "dmc",
                      "task": DMC_TASKS[stem], "level": "train", "unit": "return", "budget": str(frame),
                      "budget_unit": "frames", "seeds": str(len(values)), "seed": "",
                      "where": f"curves/{path.name}, frame {frame}"}
            std = float(np.std(values, ddof=1)) if len(values) > 1 else float("nan")
            rows.append({**common, "statistic": "mean", "value": number_text(np.mean(values)),
                         "spread": number_text(std), "spread_kind": "std"})
            rows.append({**common, "statistic": "median", "value": number_text(np.median(values)),
                         "spread": "", "spread_kind": ""})
        counts[path.name] = 2 * len(by_frame)
    return rows, counts


# ------------------------------------------------------------------------------------------- output


def sort_key(row: dict) -> tuple:
    return (row["method"], row["suite"], row["task"], row["level"], int(row["budget"] or -1),
            row["statistic"], int(row["seed"] or 0))


def csv_text(rows: list[dict]) -> str:
    rows = sorted(rows, key=sort_key)
    keys = [sort_key(row) for row in rows]
    if len(set(keys)) != len(keys):
        raise SourceError("two rows share method, suite, task, level, budget, statistic and seed")
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=SCHEMA, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


def write_atomic(path: Path, text: str) -> None:
    """Write a temp file beside ``path``, then rename it over ``path`` (readers never see half a file)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=DEFAULT_SHARED,
                        help=f"the shared data folder (default: {DEFAULT_SHARED})")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output folder (default: {DEFAULT_OUT})")
    parser.add_argument("--overwrite", action="store_true", help="replace CSV files that already exist")
    args = parser.parse_args(argv)

    xlsx = args.shared / "rlvigen" / "evaluation_score.xlsx"
    curves = args.shared / "drqv2_curves"
    targets = {"rlvigen": args.out / "rlvigen.csv", "drqv2": args.out / "drqv2.csv"}
    for needed in (xlsx, curves):
        if not needed.exists():
            parser.error(f"{needed} not found")
    if importlib.util.find_spec("openpyxl") is None:
        parser.error("openpyxl is needed to read the RL-ViGen workbook "
                     "(e.g. pip install --target /tmp/oxl openpyxl, then PYTHONPATH=/tmp/oxl)")
    existing = [str(p) for p in targets.values() if p.exists()]
    if existing and not args.overwrite:
        parser.error(f"refusing to overwrite {', '.join(existing)} (pass --overwrite)")

    notes: list[str] = []
    rl_rows, rl_counts = rlvigen_rows(xlsx, notes)
    dq_rows, dq_counts = drqv2_rows(curves)
    texts = {"rlvigen": csv_text(rl_rows), "drqv2": csv_text(dq_rows)}  # everything built before writing

    args.out.mkdir(parents=True, exist_ok=True)
    for name, path in targets.items():
        write_atomic(path, texts[name])
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    for name, counts in (("rlvigen", rl_counts), ("drqv2", dq_counts)):
        detail = ", ".join(f"{key} {n}" for key, n in counts.items())
        print(f"{targets[name]}: {sum(counts.values())} rows ({detail})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
