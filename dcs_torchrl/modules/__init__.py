"""Networks and image augmentations of the paper's baselines (Stone et al. 2021, section 4).

>>> from dcs_torchrl.modules import RandomShift, make_encoder, make_sac_actor, make_critic
"""
from dcs_torchrl.modules.allocator import retain_freed_memory
from dcs_torchrl.modules.augment import (
    ObservationNoise,
    RandomCrop,
    RandomShift,
    augmentation_copies,
    with_next_keys,
)
from dcs_torchrl.modules.networks import (
    FlatEncoder,
    PixelEncoder,
    QHead,
    TanhGaussianHead,
    action_bounds,
    conv_trunk,
    make_critic,
    make_encoder,
    make_sac_actor,
    mlp,
    orthogonal_init,
)

__all__ = [
    "FlatEncoder",
    "ObservationNoise",
    "PixelEncoder",
    "QHead",
    "RandomCrop",
    "RandomShift",
    "TanhGaussianHead",
    "action_bounds",
    "augmentation_copies",
    "conv_trunk",
    "make_critic",
    "make_encoder",
    "make_sac_actor",
    "mlp",
    "orthogonal_init",
    "retain_freed_memory",
    "with_next_keys",
]
