"""The committed results (docs/results/<task>/) are what their per-episode rows say: every derived table recomputed."""

from __future__ import annotations

import csv
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from vigen.datasets.identity import label_parts, parse_identity
from vigen.results import published

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = sorted(path.parent for path in (ROOT / "docs" / "results").glob("*/episodes.csv"))
SPEC = importlib.util.spec_from_file_location("results_report", ROOT / "scripts" / "results_report.py")
results_report = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(results_report)


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as file:
        return list(csv.DictReader(file))


def same_cell(committed: str, recomputed: object) -> bool:
    if isinstance(recomputed, float) or isinstance(recomputed, int) and not isinstance(recomputed, bool):
        if committed in ("", "nan"):
            return math.isnan(float(recomputed))
        return math.isclose(float(committed), float(recomputed), rel_tol=1e-9, abs_tol=1e-9)
    return committed == ("" if recomputed is None else str(recomputed))


def test_there_are_results_to_check():
    assert [folder.name for folder in FOLDERS] == ["cartpole-balance", "cartpole-balance-benchmark-data"]


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda folder: folder.name)
def test_derived_tables_recompute_from_the_rows(folder):
    rows = results_report.read_rows(folder / "episodes.csv")
    settings = (folder / "report_settings.txt").read_text().split()
    compare_with = settings[settings.index("--compare") + 1] if "--compare" in settings else None
    methods = settings[settings.index("--methods") + 1:settings.index("--methods") + 3] if "--methods" in settings else None
    tables = results_report.derive(rows, compare_with=compare_with, methods=methods)
    for name, lines in tables.items():
        committed = read_csv(folder / f"{name}.csv")
        assert len(committed) == len(lines), name
        for saved, line in zip(committed, lines):
            assert set(saved) == {key for key in line}, name
            wrong = {key: (saved[key], line[key]) for key in saved if not same_cell(saved[key], line[key])}
            assert not wrong, f"{folder.name}/{name}.csv differs from its rows: {wrong}"


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda folder: folder.name)
def test_rows_cover_every_run_level_and_episode(folder):
    rows = results_report.read_rows(folder / "episodes.csv")
    levels = list(dict.fromkeys(row["level"] for row in rows))
    counts = {}
    for row in rows:
        key = (row["method"], row["run"], row["level"])
        counts[key] = counts.get(key, 0) + 1
    agents = {key[:2] for key in counts if key[0] != "random"}
    assert all(counts.get((*agent, level)) == 10 for agent in agents for level in levels), "10 episodes per run and level"
    assert counts.get(("random", 0, "train")) == 10, "the random baseline at least on the training level"
    assert len(agents) >= (6 if folder.name == "cartpole-balance" else 2)


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda folder: folder.name)
def test_every_row_says_what_its_level_showed(folder):
    rows = results_report.read_rows(folder / "episodes.csv")
    assert all({"data", "stand_in", "level_options"} <= set(row) for row in rows)
    for row in rows:
        assert (row["data"] == "") == (row["level"] in ("train", "rotate_easy", "shift_easy")), row["level"]
        assert row["stand_in"] == ("stand-in" in row["data"]), row["level"]
    if folder.name == "cartpole-balance-benchmark-data":  # the benchmarks' own data, and which of it each episode saw
        assert not any(row["stand_in"] for row in rows)
        labels = {part.strip() for row in rows for part in label_parts(row["data"]) if part}
        assert all(parse_identity(label) is not None for label in labels), "every label names a data set, no path"
        assert {row["data"] for row in rows if row["level"] == "video_easy"} == {
            "dmcgb-videos/video_easy: 6 of 10, not verified, given as a folder"}, "6 copied files no level checked"
        assert {row["data"] for row in rows if row["level"] == "video_hard"} == {"dmcgb-videos/video_hard: 100 of 100, verified"}
        hard = [row["shown"] for row in rows if row["level"] == "video_hard" and row["method"] == "svea"]
        assert hard == [f"video=video{k + 1}.mp4" for k in range(10)], "DMC-GB's order: episode k plays video k + 1"


def test_a_changed_row_changes_the_summary():
    folder = FOLDERS[0]
    rows = results_report.read_rows(folder / "episodes.csv")
    before = results_report.summarize(rows, reps=100)
    rows[0] = dict(rows[0], **{"return": rows[0]["return"] + 500.0})
    after = results_report.summarize(rows, reps=100)
    assert before[0]["mean"] != after[0]["mean"]


def episode_rows(method: str, run_means: list[float], spread: float, level: str = "color_hard") -> list[dict]:
    """10 episodes per run around each mean, ± ``spread`` (mean exact), for the report's verdict rules."""
    return [{"method": method, "run": run, "env": "dmc/cartpole-balance", "level": level, "return": mean + spread * sign}
            for run, mean in enumerate(run_means) for sign in (-1, 1) * 5]


def test_a_level_is_resolved_only_by_the_stated_test_on_a_margin_above_the_errors():
    def verdict(svea, drqv2, spread):
        rows = episode_rows("svea", svea, spread) + episode_rows("drqv2", drqv2, spread)
        return results_report.direction(results_report.improvements(rows, reps=50), rows, "svea", "drqv2")[0]

    clear = verdict([900.0, 910.0, 920.0], [300.0, 310.0, 320.0], spread=10.0)
    assert clear["p_value"] == pytest.approx(0.05) and clear["verdict"] == "svea better"
    # every pair of runs agrees (p = 0.05, the floor for 3 runs each), but the closest runs differ by 2 points
    # while each run's mean has a standard error of about 100 / sqrt(10) = 31.6: more episodes could flip it
    fragile = verdict([502.0, 910.0, 920.0], [300.0, 310.0, 500.0], spread=100.0)
    assert fragile["p_value"] == pytest.approx(0.05) and fragile["fragile"]
    run_error = 100.0 * (10 / 9) ** 0.5 / 10 ** 0.5  # each run's SE: the episodes' sample std over sqrt(10)
    assert fragile["margin"] == pytest.approx(2.0) and fragile["error"] == pytest.approx(2 ** 0.5 * run_error), \
        "the SE of the difference of two run means, sqrt(SE1² + SE2²)"
    assert fragile["verdict"].startswith("not resolved (fragile")
    # a margin between twice the larger run SE and twice the SE of the difference: fragile by the difference's SE
    between = verdict([300.0 + 2.3 * run_error, 910.0, 920.0], [100.0, 110.0, 300.0], spread=100.0)
    assert 2 * run_error < between["margin"] < 2 * 2 ** 0.5 * run_error and between["p_value"] == pytest.approx(0.05)
    assert between["fragile"] and between["verdict"].startswith("not resolved (fragile")
    mixed = verdict([900.0, 200.0, 920.0], [300.0, 310.0, 320.0], spread=1.0)  # one svea run below every drqv2 run
    assert mixed["p_value"] == pytest.approx(0.35) and mixed["verdict"] == "not resolved"
    assert results_report.smallest_p_value(3, 3) == pytest.approx(0.05)


def test_the_benchmark_data_page_sets_madis_rows_beside_the_shipped_agents_as_they_are():
    folder = ROOT / "docs" / "results" / "cartpole-balance-benchmark-data"
    lines = [line for line in (folder / "README.md").read_text().splitlines() if line.startswith(("| MaDi", "| vigen"))]
    cells = {line.split(" | ")[0].lstrip("| "): line.rstrip(" |").rsplit(" | ", 1)[-1] for line in lines}
    madi = {row.method: f"{row.value:.0f} ± {row.spread:.0f}" for row in published(source="madi", task="cartpole-balance")}
    assert len(madi) == 7 and sorted(value for who, value in cells.items() if who.startswith("MaDi")) == sorted(madi.values())
    assert cells["MaDi's SVEA"] == madi["svea"] == "579 ± 58" and cells["MaDi"] == madi["madi"]
    rows = results_report.read_rows(folder / "episodes.csv")
    for who, method in (("vigen DrQ-v2 (shipped)", "drqv2"), ("vigen SVEA (shipped)", "svea")):
        returns = np.array([row["return"] for row in rows if row["method"] == method and row["level"] == "video_hard"])
        assert cells[who] == f"{returns.mean():.1f} ± {returns.std(ddof=1):.1f} (std over {len(returns)} episodes)"
