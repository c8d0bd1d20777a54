#!/bin/bash
# The GPU checks of docs/performance.md ("GPU") in one call per stage, for a GPU box reached for
# a few minutes: each step under its own timeout, every output under $OUT (default gpu_check/).
#
#   bash benchmarks/gpu_check.sh quick    # the GPU, its EGL devices, the CUDA tests, the renderer scores (~3 min)
#   bash benchmarks/gpu_check.sh speed    # benchmarks/gpu_speed.py, its full table (~6 min)
#   bash benchmarks/gpu_check.sh learn    # docs/training.md's short run (16K frames) with device=cuda (~2 min)
#   bash benchmarks/gpu_check.sh parallel # benchmarks/parallel_speed.py with 16 workers (#cores of such a box)
#   bash benchmarks/gpu_check.sh suite    # the whole test suite with the NVIDIA EGL driver (pytest -n 16; every
#                                         # failure listed, junit XML beside it)
#
# On a bare box made ready by ../shared/device/prepare.sh-style wheels, source their
# on_device.sh first; elsewhere the installed package is used as it is. Such a box lacks
# Gymnasium (the [gym] extra): without it the suite leaves out its tests and says so at the end of its
# output (conftest.py). To run them there too, add its wheels before going:
#   python -m pip download --no-deps --only-binary=:all: --python-version 3.12 --platform any \
#       -d .whl "gymnasium==$(python -m pip show gymnasium | awk '/^Version/{print $2}')" farama-notifications cloudpickle
set -u
stage=${1:-quick}
OUT=${OUT:-gpu_check}
mkdir -p "$OUT"
export MUJOCO_GL=${MUJOCO_GL:-egl}
step() {  # step <name> <seconds> <command...>: its output in $OUT/<name>.txt, its exit status printed
  local name=$1 seconds=$2
  shift 2
  timeout "$seconds" "$@" > "$OUT/$name.txt" 2>&1
  echo "$name: exit $? ($(tail -n 1 "$OUT/$name.txt"))"
}
case $stage in
  quick)
    step machine 30 bash -c 'nvidia-smi; lscpu | grep "Model name"; python3 -c "import torch; print(torch.__version__, torch.version.cuda, torch.backends.cudnn.version())"'
    step egl_devices 30 python3 -c 'from dcs_torchrl.egl_devices import egl_devices; [print(d.describe(), d.extensions) for d in egl_devices()]'
    step test_cuda 240 python3 -m pytest -q -p no:cacheprovider tests/training/test_cuda.py tests/test_egl_devices.py tests/test_parallel.py
    step renderer_scores 200 bash -c 'cd benchmarks && python3 renderer_scores.py --episodes 20 --device cuda'
    ;;
  speed)
    step gpu_speed 540 python3 benchmarks/gpu_speed.py
    ;;
  learn)
    step learn_cuda 480 python3 recipes/sac/sac.py algo.aug=rad env.benchmark=easy total_frames=16000 \
      algo.batch_size=128 eval.interval=4000 eval.periodic_episodes=5 eval.episodes=10 checkpoint.interval=4000 \
      device=cuda progress=false hydra.run.dir=/tmp/gpu_check_learn
    cp /tmp/gpu_check_learn/results.json /tmp/gpu_check_learn/metrics.csv "$OUT/"
    ;;
  parallel)
    step parallel_speed 540 python3 benchmarks/parallel_speed.py --workers 16 --steps 100 --rounds 3 \
      --only "one env" ParallelEnv ParallelSuiteEnv "ParallelSuiteEnv, unlocked" "16 processes"
    ;;
  suite)
    step suite 560 python3 -m pytest -q -rfE -p no:cacheprovider -n 16 --junitxml="$OUT/suite.xml"
    ;;
  *)
    echo "unknown stage $stage: quick, speed, learn, parallel or suite" >&2
    exit 2
    ;;
esac
