#!/usr/bin/env bash
# Issue 32's learning runs on the lent H100 (docs/results/cartpole-balance/README.md). Call 1 on the device: install,
# start the 6 learning runs in the background (setsid: they outlive this call while the machine stays warm), watch them
# until DEADLINE seconds, then export the newest checkpoints.
set -u
T0=$(date +%s); DEADLINE=${DEADLINE:-520}
source benchmarks/gpu_runs/common.sh
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 3
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
mkdir -p $R
for algo in drqv2 svea; do for seed in 0 1 2; do
  command="python examples/train.py --algo $algo --env dmc/cartpole-balance --preset paper --buffer-size 100000 \
--seed $seed --frames $FRAMES --eval-every 10000 --eval-episodes 5 --threads 2 --device cuda"
  echo "$command" > $R/$algo-s$seed.command  # the export records it in the agent's provenance
  setsid nohup ${command/python/python3} --out $R/$algo-s$seed > $R/$algo-s$seed.log 2>&1 < /dev/null &
done; done
sleep 5
watch_runs 30
python3 benchmarks/gpu_runs/export_runs.py $R $OUT part1 2>&1 | grep -v Warning
nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv
echo "done at $(( $(date +%s) - T0 )) s"
