# Sourced by start_runs.sh and finish_runs.sh: the environment the runs and the export need, and the watch loop.
R=/tmp/runs                 # the run folders, on the device machine
FRAMES=40000                # what each run is started for
TARGET=${TARGET:-$FRAMES}   # the checkpoint (frames) every run must reach before the export
export PYTHONPATH=/tmp/site:$PWD/benchmarks/gpu_runs/dmc:$PWD MUJOCO_GL=egl PYTHONUNBUFFERED=1
vendor=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f $vendor ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$vendor

# watch_runs EVERY: one progress line per EVERY seconds until every run has its TARGET checkpoint or DEADLINE passes
watch_runs() {
  while [ $(( $(date +%s) - T0 )) -lt $DEADLINE ]; do
    n=$(ls $R/*/checkpoints/frames_$(printf %08d $TARGET).pt 2>/dev/null | wc -l); [ "$n" -ge 6 ] && break
    sleep "$1"
    line="t=$(( $(date +%s) - T0 ))s"
    for l in $R/*.log; do line="$line | $(basename $l .log) $(tr '\r' '\n' < $l | grep -oE "[0-9]+/$FRAMES.*" | tail -1 | cut -c1-60)"; done
    echo "$line"
  done
  for l in $R/*.log; do echo "== $l"; tr '\r' '\n' < $l | grep -vE '^\s*[0-9]+%' | grep -v Warning | tail -4; done
}
