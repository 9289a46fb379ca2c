#!/usr/bin/env bash
# Call 2 on the same warm machine: wait for the background runs (until DEADLINE s), then export again.
set -u
TARGET=${TARGET:-40000}  # the checkpoint (frames) every run must reach before the export
T0=$(date +%s); DEADLINE=${DEADLINE:-150}
export PYTHONPATH=/tmp/site:$PWD/benchmarks/gpu_runs/dmc:$PWD MUJOCO_GL=egl PYTHONUNBUFFERED=1
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
R=/tmp/runs
while [ $(( $(date +%s) - T0 )) -lt $DEADLINE ]; do
  n=$(ls $R/*/checkpoints/frames_$(printf %08d $TARGET).pt 2>/dev/null | wc -l); [ "$n" -ge 6 ] && break
  sleep 10
  line="t=$(( $(date +%s) - T0 ))s"
  for l in $R/*.log; do line="$line | $(basename $l .log) $(tr '\r' '\n' < $l | grep -oE '[0-9]+/40000.*' | tail -1 | cut -c1-50)"; done
  echo "$line"
done
for l in $R/*.log; do echo "== $l"; tr '\r' '\n' < $l | grep -vE '^\s*[0-9]+%' | grep -v Warning | tail -3; done
python3 benchmarks/gpu_runs/export_runs.py $R $OUT part2 2>&1 | grep -v Warning
echo "done at $(( $(date +%s) - T0 )) s"
