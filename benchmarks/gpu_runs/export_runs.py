"""On the device: export each run folder's newest checkpoint (encoder and actor, float16) and pack agents and logs into OUT.

    python benchmarks/gpu_runs/export_runs.py /tmp/runs "$OUT" part1

Two agents per tar, so that each file that comes back stays under the device tool's 16 MiB. The
provenance's commit is read from ``COMMIT`` beside this file (the device's copy has no .git):
``git rev-parse HEAD > benchmarks/gpu_runs/COMMIT`` before the call.
"""
import sys
import tarfile
from pathlib import Path
import torch
from vigen.pretrained import export_policy
from vigen.run import load_agent
from vigen.run.agent import env_action_spec

runs, out, tag = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
commit = (Path(__file__).parent / "COMMIT").read_text().strip()
stage = Path("/tmp/export") / tag
stage.mkdir(parents=True, exist_ok=True)
names = []
for run in sorted(p for p in runs.iterdir() if p.is_dir()):
    try:
        trained = load_agent(run)
    except Exception as error:  # noqa: BLE001 - report and go on
        print(f"{run.name}: no checkpoint ({error})", flush=True)
        continue
    config = trained.config
    command = (runs / f"{run.name}.command").read_text().strip()  # written by start_runs.sh as it started the run
    provenance = {"commit": commit, "command": command, "algo": config.algo, "env": config.env, "seed": config.seed,
                  "frames": trained.frames, "checkpoint": trained.checkpoint.name,
                  "trained_on": f"{torch.cuda.get_device_name(0) if torch.cuda.is_available() else 'cpu'}, torch {torch.__version__}"}
    name = f"{config.algo}-s{config.seed}"
    export_policy(config, trained.agent.loss, env_action_spec(config), stage, name, provenance, overwrite=True)
    names.append(name)
    print(f"{name}: exported at {trained.frames} frames", flush=True)
# two agents per tar (each file back must stay under 16 MiB)
for i in range(0, len(names), 2):
    with tarfile.open(out / f"{tag}_agents{i // 2}.tar", "w") as tar:
        for name in names[i:i + 2]:
            tar.add(stage / f"{name}.pt", arcname=f"{name}.pt")
            tar.add(stage / f"{name}.json", arcname=f"{name}.json")
with tarfile.open(out / f"{tag}_logs.tar.gz", "w:gz") as tar:
    for run in sorted(p for p in runs.iterdir() if p.is_dir()):
        tar.add(run / "config.json", arcname=f"{run.name}/config.json")
        tar.add(run / "logs", arcname=f"{run.name}/logs")
    for log in runs.glob("*.log"):
        tar.add(log, arcname=log.name)
print("packed", names, flush=True)
