"""SAC, SAC+RAD and SAC+DrQ from pixels on the Distracting Control Suite: the Hydra entry point.

    python recipes/sac/sac.py env.domain=cartpole env.task=swingup env.benchmark=easy algo.aug=rad

The same as ``python -m dcs_torchrl.training --config-name=sac ...`` (an installed package needs no
clone). The algorithm is :class:`dcs_torchrl.algorithms.SACAgent` (its docstring: what the paper
runs and where each choice comes from); everything around the update (envs, replay, logging,
evaluation, checkpoints) is :func:`dcs_torchrl.training.train`. Settings:
``dcs_torchrl/training/conf/sac.yaml`` over ``base.yaml``. Every output goes to Hydra's run directory.
"""
from dcs_torchrl.training.cli import recipe_main

main = recipe_main("sac")

if __name__ == "__main__":
    main()
