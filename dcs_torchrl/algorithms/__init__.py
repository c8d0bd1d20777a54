"""The agents of the paper's two algorithms (:mod:`dcs_torchrl.methods` names the six methods).

>>> from dcs_torchrl.algorithms import QTOptAgent, SACAgent
"""
from dcs_torchrl.algorithms.qtopt import QTOptAgent
from dcs_torchrl.algorithms.sac import SACAgent

__all__ = ["QTOptAgent", "SACAgent"]
