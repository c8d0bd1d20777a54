"""The recipes' Hydra configs: ``base.yaml`` (shared), ``sac.yaml``, ``qtopt.yaml``, ``evaluate.yaml``.

``base.yaml`` writes out the ``env`` (the training env) and ``eval_env`` (its overrides for
evaluation) sections: their keys are the task and the scene options of
:class:`dcs_torchrl.EnvOptions` (:data:`dcs_torchrl.envs.SCENE_OPTIONS`), with its defaults; a
test checks that they agree. Hydra refuses an unknown ``env.<key>`` (the config is in struct
mode); the recipes refuse a value of the wrong type
(:func:`dcs_torchrl.training.envs.config_settings`).
"""
