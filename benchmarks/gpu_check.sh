#!/usr/bin/env bash
# The device check (issue 40) in one command on the lent GPU machine, from a fresh copy of the repository with the folder
# that `python scripts/gpu_carry.py` builds (.gpu-carry, carried): install, then the device tests, DrQ-v2 and SVEA against
# the reference, a minute of training and the other losses, stopping itself before 8 minutes. benchmarks/gpu_check.py says
# what each stage does; docs/performance.md how to run it. Results: $OUT/figures.json and $OUT/logs/*.log.
#   bash benchmarks/gpu_check.sh                       # on the GPU machine (python3 there holds torch with CUDA)
#   bash benchmarks/gpu_check.sh --dry --carry none    # the same stages on this CPU at tiny sizes, in seconds
export GPU_CHECK_T0=${GPU_CHECK_T0:-$(date +%s.%N)}  # the deadline counts from here, install included
cd "$(dirname "$0")/.."
exec "${PYTHON:-python3}" benchmarks/gpu_check.py "$@"
