"""Losses of the paper's baselines: SAC and QT-Opt, each with K = M in {0, 1, 2} DrQ copies.

>>> from dcs_torchrl.objectives import DrQSACLoss, QTOptLoss, CEMActor
"""
from dcs_torchrl.objectives.cem import CEMActor, cem_maximize
from dcs_torchrl.objectives.drq import DrQEncoding, augmented_copies
from dcs_torchrl.objectives.qtopt import QTOptLoss, averaged_cross_entropy
from dcs_torchrl.objectives.sac import DrQSACLoss

__all__ = ["CEMActor", "DrQEncoding", "DrQSACLoss", "QTOptLoss", "augmented_copies", "averaged_cross_entropy", "cem_maximize"]
