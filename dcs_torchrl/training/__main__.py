"""``python -m dcs_torchrl.training [--config-name=sac|qtopt] <overrides>``: see :mod:`dcs_torchrl.training.cli`."""
from dcs_torchrl.training.cli import main

if __name__ == "__main__":
    main()
