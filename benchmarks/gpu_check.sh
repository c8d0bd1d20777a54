#!/bin/bash
# The GPU checks of docs/performance.md ("GPU") in one call per stage, for a GPU box reached for
# a few minutes: each step under its own timeout, every output under $OUT (default gpu_check/).
#
#   bash benchmarks/gpu_check.sh quick    # the GPU, its EGL devices, the CUDA tests, the renderer scores (~3 min)
#   bash benchmarks/gpu_check.sh speed    # benchmarks/gpu_speed.py, its full table (~6 min)
#   bash benchmarks/gpu_check.sh learn    # docs/training.md's short run (16K frames) with device=cuda (~2 min)
#   bash benchmarks/gpu_check.sh parallel # benchmarks/parallel_speed.py with 16 workers (#cores of such a box)
#   bash benchmarks/gpu_check.sh concurrent # benchmarks/concurrent_runs.py: 1, 2, 4, 8 recipe runs at once on the GPU (~5 min)
#   bash benchmarks/gpu_check.sh batched  # CUDA frames against CPU Warp frames; the batch's physics alone on every
#                                         # core (--physics-only); batched_speed.py --device cuda: the Warp backend, N up
#                                         # to 4096, cartpole medium dynamic, with the physics / scene / render shares, and
#                                         # the batch shared among 16 processes (processes=16) (needs
#                                         # mujoco-warp and warp-lang: warp-lang's wheel, ~150 MB, exceeds one
#                                         # call's 64 MiB: carry it in parts (split -b 60M) over consecutive calls
#                                         # and join them in a scratch folder there, then pip install --no-deps)
#   bash benchmarks/gpu_check.sh suite    # the whole test suite with the NVIDIA EGL driver (pytest -n 16; every
#                                         # failure listed, junit XML beside it)
#   bash benchmarks/gpu_check.sh lease    # what fits one 10-minute call, most needed first (a 15-minute loan:
#                                         # the box's start, ~30 s; this; the transfers): the GPU and its EGL
#                                         # devices, the CUDA tests, gpu_speed.py at batch 512 alone (phases, then
#                                         # SAC+DrQ's loop rows), then together in what is left: the renderer
#                                         # scores (10 episodes) and the suite. Ends by $DEADLINE seconds (540)
#
# On a bare box made ready by ../shared/device/prepare.sh-style wheels, source their
# on_device.sh first; elsewhere the installed package is used as it is. Such a box lacks
# Gymnasium (the [gym] extra): without it the suite leaves out its tests and says so at the end of its
# output (conftest.py). To run them there too, add its wheels before going:
#   python -m pip download --no-deps --only-binary=:all: --python-version 3.12 --platform any \
#       -d .whl "gymnasium==$(python -m pip show gymnasium | awk '/^Version/{print $2}')" farama-notifications cloudpickle
# The suite's workers get two torch threads each, as on a 2-core CI machine (torch's default there:
# 16 each, 256 threads on 16 cores). prepare.sh's slimmed dm_control wheel has no dog assets: there
# the suite deselects the dog tests (they fail with StopIteration inside dm_control.suite.dog) and
# says so.
set -u
stage=${1:-quick}
OUT=${OUT:-gpu_check}
mkdir -p "$OUT"
export MUJOCO_GL=${MUJOCO_GL:-egl}
step() {  # step <name> <seconds> <command...>: its output in $OUT/<name>.txt, its exit status printed
  # (at the limit an interrupt, so that pytest and the benchmarks print what they have; a kill 20 s later)
  local name=$1 seconds=$2
  shift 2
  timeout -s INT -k 20 "$seconds" "$@" > "$OUT/$name.txt" 2>&1
  echo "$name: exit $? ($(tail -n 1 "$OUT/$name.txt"))"
}
left() {  # left <most>: seconds to give the next step, at most <most>, so that the stage ends by $DEADLINE
  local rest=$((DEADLINE - SECONDS))
  rest=$((rest < $1 ? rest : $1))
  echo $((rest > 1 ? rest : 1))
}
# the agents whose clean scores the loan compares across renderers (#35 item 6): the two first shipped
export SCORED="sac_rad_cartpole_swingup sac_rad_ball_in_cup_catch"
MACHINE='nvidia-smi; lscpu | grep "Model name"
  python3 -c "import torch; print(torch.__version__, torch.version.cuda, torch.backends.cudnn.version())"
  python3 -c "from dcs_torchrl.render.egl_devices import egl_devices; [print(d.describe(), d.extensions) for d in egl_devices()]"'
SECONDS=0
DEADLINE=${DEADLINE:-540}
suite_args=(-q -rfE -p no:cacheprovider)
if ! python3 -c "import os, dm_control.suite.dog as d; os.listdir(d._ASSET_DIR)" 2>/dev/null; then
  echo "dm_control has no dog assets here (a slimmed wheel): the dog tests are deselected"
  suite_args+=(-k "not dog")
fi
case $stage in
  quick)
    step machine 60 bash -c "$MACHINE"
    step test_cuda 240 python3 -m pytest -q -p no:cacheprovider tests/training/test_cuda.py tests/test_egl_devices.py tests/test_parallel.py
    step renderer_scores 200 bash -c 'cd benchmarks && python3 renderer_scores.py --episodes 20 --device cuda --agents $SCORED'
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
      --only "one env" ParallelEnv ParallelSuiteEnv "ParallelSuiteEnv, all in workers" "ParallelSuiteEnv, unlocked" "16 processes"
    ;;
  concurrent)
    step concurrent_runs 540 python3 benchmarks/concurrent_runs.py --runs 1 2 4 8
    ;;
  batched)
    step machine 60 bash -c "$MACHINE"
    # each order in its own process: a CUDA error poisons the process for the tests after it
    step cuda_first "$(left 150)" python3 -m pytest -q -rfE -p no:cacheprovider -p no:benchmark tests/test_batched.py -k "cuda_frames and cuda-first"
    step cpu_first "$(left 150)" python3 -m pytest -q -rfE -p no:cacheprovider -p no:benchmark tests/test_batched.py -k "cuda_frames and cpu-first"
    step physics_only "$(left 150)" python3 benchmarks/batched_speed.py --physics-only --sizes 128 --rounds 1 --seconds 2 \
      --tasks cartpole:swingup walker:walk --processes 16
    step batched_speed "$(left 300)" python3 benchmarks/batched_speed.py --device cuda --no-gl --tasks cartpole:swingup \
      --presets medium --sizes 256 1024 --rounds 2 --seconds 3 --processes 16
    # N = 4096 in one process has its row in docs/performance.md ("GPU"): here the batch shared among 16 processes
    step batched_4096 "$(left 400)" python3 benchmarks/batched_speed.py --device cuda --no-gl --tasks cartpole:swingup \
      --presets medium --sizes 4096 --rounds 1 --seconds 4 --processes 16 --processes-only
    ;;
  suite)
    step suite 560 env OMP_NUM_THREADS=2 python3 -m pytest "${suite_args[@]}" -n 16 --junitxml="$OUT/suite.xml"
    ;;
  lease)
    step machine 60 bash -c "$MACHINE"
    step test_cuda "$(left 150)" python3 -m pytest -q -rfE -p no:cacheprovider tests/training/test_cuda.py tests/test_egl_devices.py
    # the timed steps alone on the box
    step gpu_speed "$(left 120)" python3 benchmarks/gpu_speed.py --batch-sizes 512 --loop-steps 0 \
      --variants eager cudagraph cudagraph+nchw cudagraph+tf32 cudagraph+tf32+nchw
    step gpu_loop "$(left 180)" python3 benchmarks/gpu_speed.py --methods sac --batch-sizes 512 \
      --variants eager cudagraph+tf32 --no-flops --updates 5
    # then the untimed ones together, with few threads each (on the first try, the suite's workers
    # at torch's 16 threads each left a run beside them at 24 frames/s)
    rest=$(left 600)
    step renderer_scores "$rest" env OMP_NUM_THREADS=2 bash -c 'cd benchmarks && python3 renderer_scores.py --episodes 10 --device cuda --agents $SCORED' &
    step suite "$rest" env OMP_NUM_THREADS=2 python3 -m pytest "${suite_args[@]}" -n 12 &
    wait
    ;;
  *)
    echo "unknown stage $stage: quick, speed, learn, parallel, concurrent, batched, suite or lease" >&2
    exit 2
    ;;
esac
