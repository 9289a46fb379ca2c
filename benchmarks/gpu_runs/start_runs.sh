#!/usr/bin/env bash
# Issue 32's learning runs on the lent H100 (docs/results/cartpole-balance/README.md). Call 1 on the device: install, start the 6 learning runs in the background (setsid: they outlive this call
# while the machine stays warm), watch them until DEADLINE seconds, then export the newest checkpoints.
set -u
TARGET=${TARGET:-40000}  # the checkpoint (frames) every run must reach before the export
T0=$(date +%s); DEADLINE=${DEADLINE:-520}
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 3
export PYTHONPATH=/tmp/site:$PWD/benchmarks/gpu_runs/dmc:$PWD MUJOCO_GL=egl PYTHONUNBUFFERED=1
echo "env: $(cat /proc/cpuinfo | grep -c processor) cpus; setup $(( $(date +%s) - T0 )) s"
python3 -c "
import torch, time
from vigen.envs import make_env
from vigen.rendering import RenderSettings
e = make_env('dmc/cartpole-balance', seed=0, render_settings=RenderSettings.fast())
td = e.reset(); t = time.time()
for _ in range(50): td = e.rand_step(td)
print('env ok', td['pixels'].shape, f'{(time.time()-t)/50*1e3:.1f} ms/step', torch.__version__, torch.cuda.get_device_name(0))
" 2>&1 | grep -v Warning | tail -3 || exit 4
R=/tmp/runs; mkdir -p $R
for algo in drqv2 svea; do for seed in 0 1 2; do
  setsid nohup python3 examples/train.py --algo $algo --env dmc/cartpole-balance --preset paper --buffer-size 100000 \
    --seed $seed --frames 40000 --eval-every 10000 --eval-episodes 5 --threads 2 --device cuda \
    --out $R/$algo-s$seed > $R/$algo-s$seed.log 2>&1 < /dev/null &
done; done
sleep 5
while [ $(( $(date +%s) - T0 )) -lt $DEADLINE ]; do
  sleep 30
  line="t=$(( $(date +%s) - T0 ))s"
  for l in $R/*.log; do line="$line | $(basename $l .log) $(tr '\r' '\n' < $l | grep -oE '[0-9]+/40000.*' | tail -1 | cut -c1-60)"; done
  echo "$line"
  n=$(ls $R/*/checkpoints/frames_$(printf %08d $TARGET).pt 2>/dev/null | wc -l); [ "$n" -ge 6 ] && break
done
for l in $R/*.log; do echo "== $l"; tr '\r' '\n' < $l | grep -vE '^\s*[0-9]+%' | grep -v Warning | tail -4; done
python3 benchmarks/gpu_runs/export_runs.py $R $OUT part1 2>&1 | grep -v Warning
nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv
echo "done at $(( $(date +%s) - T0 )) s"
