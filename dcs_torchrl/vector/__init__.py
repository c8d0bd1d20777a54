"""N envs at once: in worker processes (:mod:`.parallel`, GL), in one batched env (:mod:`.batched`, Warp)
whose physics :mod:`.batch_physics` steps in MuJoCo's C and whose six tasks :mod:`.task_arrays`
scores over arrays; a pool of whole jobs (:mod:`.process_pool`) and the threads they share
(:mod:`._threads`). Import from the modules (``dcs_torchrl.ParallelSuiteEnv`` and
``dcs_torchrl.make_env(..., num_envs=N)`` are the public doors)."""
