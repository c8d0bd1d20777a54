"""What an experiment's grid holds: done, failed, interrupted, running and missing runs.

    python recipes/experiments/status.py experiment=training budget=smoke [same overrides as the launch]

Prints one line per unfinished run (failed ones with the end of their error; logs:
<run dir>/train.log and <root>/status/<experiment>/<run id>.json) and the command that
relaunches only those runs. Exit code 1 if any run failed.
"""
from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from dcs_torchrl.experiments.launch import status_text


@hydra.main(config_path="conf", config_name="config", version_base=None)
def main(cfg: DictConfig) -> None:
    overrides = HydraConfig.get().overrides
    text, by_state = status_text(cfg, [*overrides.hydra, *overrides.task])
    print(text)
    if by_state["failed"]:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
