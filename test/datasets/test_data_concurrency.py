"""Two processes fetching the same data set into one cache, against a slow server on 127.0.0.1: the second waits for the
first (and names it), both end with the files in place and checked, and nothing is left half-written; for pinned files,
for a stale ``.part`` left by a killed fetch, and for DAVIS's extraction.

Before the lock, the second fetch died with FileNotFoundError on the shared ``.part`` file, or called the mirror's good
file corrupt, in 4 of 12 such rounds; many rounds are run here for that reason."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vigen.datasets import verify

pytestmark = pytest.mark.slow

ROOT = Path(__file__).parents[2]
ROUNDS = 12
FILES = {f"hard/clip{i}.bin": bytes((i * 37 + j) % 251 for j in range(64 * 1024)) for i in range(3)}

# run in each process: register the test's record (pinned files, or davis2017 with the test archive's pin), then the command
FETCH = """
import dataclasses, json, sys
import vigen.datasets as datasets
from vigen.datasets.__main__ import main
spec = json.loads(sys.argv[1])
if spec["files"]:
    files = tuple(datasets.PinnedFile(path, blob, size) for path, blob, size in spec["files"])
    datasets.DATASETS["toy"] = datasets.DataSet("toy", "t", "CC0", "this test", files=files, url_template="http://127.0.0.1:9/{path}")
else:
    davis = datasets.DATASETS["davis2017"]
    datasets.DATASETS["davis2017"] = dataclasses.replace(davis, archive=dataclasses.replace(
        davis.archive, sha256=spec["sha256"], size=spec["size"], pinned_by="this test"))
sys.exit(main(["fetch", spec["name"], "--mirror", spec["mirror"], "--root", spec["root"]]))
"""


def run_two(spec: dict) -> list[subprocess.CompletedProcess]:
    """Start two fetch processes at once with ``spec`` and wait for both."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), "OMP_NUM_THREADS": "1"}
    processes = [subprocess.Popen([sys.executable, "-c", FETCH, json.dumps(spec)], cwd=ROOT, env=env, text=True,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in range(2)]
    done = []
    for process in processes:
        out, err = process.communicate(timeout=120)
        done.append(subprocess.CompletedProcess(process.args, process.returncode, out, err))
    return done


def leftovers(folder: Path) -> list[str]:
    """Half-written things a fetch must not leave: ``.part`` files, staging folders, pooch's temporary files."""
    return sorted(p.name for p in folder.rglob("*") if p.name.endswith(".part") or p.name.startswith((".extract-", "tmp")))


def test_two_fetches_of_pinned_files_into_one_cache(server, git_blob, tmp_path):
    for relative, data in FILES.items():
        (server.folder / "toy" / relative).parent.mkdir(parents=True, exist_ok=True)
        (server.folder / "toy" / relative).write_bytes(data)
        server.faults[f"/toy/{relative}"] = "slow"
    files = [[relative, git_blob(data), len(data)] for relative, data in FILES.items()]
    waited = 0
    for round_ in range(ROUNDS):
        root = tmp_path / f"cache{round_}"
        if round_ % 3 == 2:  # a killed fetch left a .part holding other bytes: resumed, refused, fetched whole
            (root / "toy/hard").mkdir(parents=True)
            (root / "toy/hard/clip0.bin.part").write_bytes(FILES["hard/clip1.bin"][:5000])
        results = run_two({"name": "toy", "files": files, "mirror": server.url, "root": str(root)})
        for result in results:
            assert result.returncode == 0 and "error" not in result.stderr, f"round {round_}:\n{result.stderr}"
            assert result.stdout.strip() == str(root / "toy")
        waited += sum("toy: waiting for pid " in result.stderr for result in results)
        for relative, data in FILES.items():
            assert (root / "toy" / relative).read_bytes() == data, f"round {round_}: {relative}"
        assert leftovers(root) == [], f"round {round_}"
        report = verify(toy_record(files), root)
        assert report.ok and len(report.checked) == len(FILES)
    assert waited >= ROUNDS // 2, f"the second fetch waited, naming the first, in only {waited} of {ROUNDS} rounds"


def test_two_fetches_of_davis_extract_it_once(server, served_davis, tmp_path, davis_layout):
    archive = served_davis()
    server.faults["/davis2017/DAVIS-2017-trainval-480p.zip"] = "slow"
    spec = {"name": "davis2017", "files": [], "sha256": hashlib.sha256(archive).hexdigest(), "size": len(archive),
            "mirror": server.url}
    waited = 0
    for round_ in range(ROUNDS // 2):
        root = tmp_path / f"cache{round_}"
        results = run_two({**spec, "root": str(root)})
        for result in results:
            assert result.returncode == 0 and "error" not in result.stderr, f"round {round_}:\n{result.stderr}"
        waited += sum("davis2017: waiting for pid " in result.stderr for result in results)
        # one process extracted it, the other found it in place: one "done", one "already present"
        stages = sorted("extracted from the pinned archive" in r.stderr for r in results)
        assert stages == [False, True], f"round {round_}: " + "\n".join(r.stderr for r in results)
        assert any("already present, checked (in place, from the pinned archive)" in r.stderr for r in results)
        for name, data in davis_layout.items():
            assert (root / "davis2017" / name).read_bytes() == data
        assert leftovers(root) == [] and not (root / "davis2017" / "DAVIS-2017-trainval-480p.zip").exists()
        assert verify("davis2017", root).ok
    assert waited >= ROUNDS // 4, f"the second fetch waited, naming the first, in only {waited} of {ROUNDS // 2} rounds"


def toy_record(files):
    """The record the processes registered as 'toy'."""
    from vigen.datasets import DataSet, PinnedFile

    return DataSet("toy", "t", "CC0", "this test", files=tuple(PinnedFile(p, b, s) for p, b, s in files),
                   url_template="http://127.0.0.1:9/{path}")
