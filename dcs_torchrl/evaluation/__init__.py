"""Evaluating agents: the protocol (:mod:`.protocol`: episodes in one env, in a batch or in
processes) and the scheduling of many settings (:mod:`.scheduling`). The robustness command is
:mod:`dcs_torchrl.robustness`."""
from dcs_torchrl.evaluation.protocol import EVAL_THREADS, EvalResult, evaluate, evaluate_in_processes, torch_threads

__all__ = ["EVAL_THREADS", "EvalResult", "evaluate", "evaluate_in_processes", "torch_threads"]
