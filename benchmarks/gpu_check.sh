#!/usr/bin/env bash
# The GPU figures of issue 30 in one call on a CUDA machine with vigen's dependencies importable
# (../shared/reference/GPU.md says how to bring them onto the lent H100). Results go to $OUT (default ./gpu-check).
#   bash benchmarks/gpu_check.sh            # about 8 minutes on an H100, most of it compilation
set -uo pipefail
cd "$(dirname "$0")/.."
out="${OUT:-gpu-check}"
mkdir -p "$out"
python=${PYTHON:-python3}
export MUJOCO_GL=${MUJOCO_GL:-egl}
"$python" -c "import torch; print(torch.__version__, torch.cuda.get_device_name(0))" | tee "$out/device.txt"
# every device case, and the update never synchronizing with the host (eager and compiled)
"$python" -m pytest -q -p no:cacheprovider test/test_devices.py test/losses/test_update.py -k "cuda or device" \
  -m "not matrix" 2>&1 | tail -15 | tee "$out/tests.txt"
# every loss at batch 256: reference, eager, compiled + CUDA graph, GPU busy share
timeout 420 "$python" benchmarks/losses.py --device cuda --batch 256 --compile --repeats 10 2>&1 | grep -v "^W" | tee "$out/losses.txt"
# train.py end to end on walker-walk: environment frames/s, eager against compiled
timeout 300 "$python" benchmarks/train_throughput.py --device cuda --env dmc/walker-walk --frames 10000 --seed-frames 2000 \
  --batch-size 256 2>&1 | tee "$out/train_throughput.txt"
