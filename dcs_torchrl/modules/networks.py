"""The networks of Stone et al. (2021), section 4, taken from DrQ (Kostrikov et al. 2020).

* :class:`PixelEncoder`: 4 conv 3x3 layers of 32 filters (stride 2, then 1), ReLU after each,
  flatten, dense to 50, LayerNorm, tanh; pixels scaled by 1/255.
* :class:`FlatEncoder`: the same role for flat state vectors (identity, or a small MLP).
* :class:`TanhGaussianHead`: the SAC actor's 3-layer MLP (1024 hidden) giving the mean and a
  bounded log-std (DrQ's ``log_std_bounds = [-10, 2]``), for TorchRL's ``TanhNormal``.
* :class:`QHead`: a 3-layer MLP (1024 hidden) on ``[embedding, action]`` -> one Q value (SAC's
  twin critics are two of them; QT-Opt's Q-network too).

The ``make_*`` functions wrap them as TensorDict modules with the keys the losses read:
encoder ``"pixels"`` (or ``"observation"``) -> ``"embedding"``; actor ``"embedding"`` ->
``"loc"``, ``"scale"``, ``"action"``; critic ``["embedding", "action"]`` ->
``"state_action_value"``.

Initialisation follows DrQ's ``utils.weight_init``: orthogonal weights and zero biases for every
linear layer; orthogonal weights with the ReLU gain (sqrt 2) and zero biases for every convolution.

Speed (see ``benchmarks/update_speed.py``): the 1/255 scaling is folded into the first
convolution's weights (``conv(x, W / 255) == conv(x / 255, W)``, no pass over the input), the
ReLUs run in place, ``channels_last`` runs the convolutions in NHWC and ``compile`` compiles
them (:func:`conv_trunk`).
"""
from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from tensordict.nn import TensorDictModule
from tensordict.utils import NestedKey
from torch import nn
from torchrl.data.tensor_specs import Bounded, TensorSpec
from torchrl.modules import ProbabilisticActor, TanhNormal, ValueOperator

__all__ = [
    "FlatEncoder",
    "PixelEncoder",
    "QHead",
    "TanhGaussianHead",
    "action_bounds",
    "conv_trunk",
    "make_critic",
    "make_encoder",
    "make_sac_actor",
    "mlp",
    "orthogonal_init",
]


def orthogonal_init(module: nn.Module) -> None:
    """DrQ's ``weight_init``: orthogonal ``nn.Linear`` weights (gain 1) and ``nn.Conv2d`` weights
    (gain ``calculate_gain("relu")``), zero biases; other modules are left as they are."""
    if isinstance(module, (nn.Linear, nn.Conv2d)):
        gain = nn.init.calculate_gain("relu") if isinstance(module, nn.Conv2d) else 1.0
        nn.init.orthogonal_(module.weight, gain)
        if module.bias is not None:
            nn.init.zeros_(module.bias)


def mlp(in_features: int, hidden_dim: int, out_features: int, hidden_depth: int) -> nn.Sequential:
    """``hidden_depth`` hidden layers of ``hidden_dim`` units with ReLU, then a linear output.

    DrQ's ``hidden_depth=2`` gives the paper's 3-layer MLP.

    Examples:
        >>> net = mlp(50, 1024, 1, 2)
        >>> sum(isinstance(m, torch.nn.Linear) for m in net)
        3
    """
    layers: list[nn.Module] = []
    width = in_features
    for _ in range(hidden_depth):
        layers += [nn.Linear(width, hidden_dim), nn.ReLU(inplace=True)]
        width = hidden_dim
    layers.append(nn.Linear(width, out_features))
    net = nn.Sequential(*layers)
    net.apply(orthogonal_init)
    return net


def conv_trunk(pixels: torch.Tensor, weights: Sequence[torch.Tensor], biases: Sequence[torch.Tensor]) -> torch.Tensor:
    """DrQ's convolutions as a pure function: ``relu(conv(x / 255))`` then ``relu(conv(.))``.

    The first convolution has stride 2, the others 1. The 1/255 is folded into the first kernel
    (``conv(x, W / 255) == conv(x / 255, W)``: no pass over the large input) and the ReLUs run
    in place. A function of its weights (not a module) so that ``torch.compile`` sees them as
    inputs: the losses swap online and target weights in and out, which would otherwise make
    dynamo recompile on every swap.
    """
    x = F.conv2d(pixels, weights[0] * (1.0 / 255.0), biases[0], stride=2).relu_()
    for weight, bias in zip(weights[1:], biases[1:]):
        x = F.conv2d(x, weight, bias).relu_()
    return x


class PixelEncoder(nn.Module):
    """DrQ's convolutional encoder: ``[..., C, H, W]`` pixels -> ``[..., feature_dim]``.

    Args:
        in_channels (int): input channels (``3 * frame_stack`` for stacked RGB frames).

    Keyword Args:
        image_size (int): input height = width. Defaults to ``84``.
        feature_dim (int): output size. Defaults to ``50``.
        num_filters (int): filters per convolution. Defaults to ``32``.
        num_layers (int): convolutions (the first of stride 2). Defaults to ``4``.
        channels_last (bool): run the convolutions in NHWC memory format (same math, summed in
            another order; its speed: docs/performance.md, "Updates"). Defaults to ``True``.
        compile (bool): ``torch.compile`` the convolutions (:func:`conv_trunk`). Defaults to
            ``False``.

    The input may be ``uint8`` (0..255) or float on the same scale; it is divided by 255
    (folded into the first convolution). Any number of leading dimensions is accepted.

    Examples:
        >>> enc = PixelEncoder(9)
        >>> enc(torch.zeros(2, 5, 9, 84, 84, dtype=torch.uint8)).shape
        torch.Size([2, 5, 50])
    """

    def __init__(
        self,
        in_channels: int,
        *,
        image_size: int = 84,
        feature_dim: int = 50,
        num_filters: int = 32,
        num_layers: int = 4,
        channels_last: bool = True,
        compile: bool = False,
    ):
        super().__init__()
        if num_layers < 1:
            raise ValueError(f"num_layers must be at least 1, got {num_layers}.")
        self.in_channels = in_channels
        self.image_size = image_size
        self.feature_dim = feature_dim
        self.channels_last = channels_last
        convs = [nn.Conv2d(in_channels, num_filters, 3, stride=2)]
        convs += [nn.Conv2d(num_filters, num_filters, 3, stride=1) for _ in range(num_layers - 1)]
        self.convs = nn.ModuleList(convs)
        side = (image_size - 3) // 2 + 1 - 2 * (num_layers - 1)
        if side < 1:
            raise ValueError(f"image_size {image_size} is too small for {num_layers} convolutions.")
        self.conv_output_shape = (num_filters, side, side)
        self.linear = nn.Linear(num_filters * side * side, feature_dim)
        self.norm = nn.LayerNorm(feature_dim)
        self.apply(orthogonal_init)
        if channels_last:
            self.convs.to(memory_format=torch.channels_last)
        # dynamic: one graph for every batch size (acting 1, update B, DrQ's 2B); a static graph
        # recompiled per size until dynamo's recompile limit and then fell back to eager
        self._trunk = torch.compile(conv_trunk, dynamic=True) if compile else conv_trunk

    def forward_conv(self, pixels: torch.Tensor) -> torch.Tensor:
        """The convolutional trunk: ``[N, C, H, W]`` -> ``[N, filters, side, side]``."""
        x = pixels if pixels.dtype == self.linear.weight.dtype else pixels.to(self.linear.weight.dtype)
        if self.channels_last:
            x = x.contiguous(memory_format=torch.channels_last)
        return self._trunk(x, [c.weight for c in self.convs], [c.bias for c in self.convs])

    def forward(self, pixels: torch.Tensor) -> torch.Tensor:
        if pixels.ndim < 3 or pixels.shape[-3] != self.in_channels:
            raise ValueError(
                f"PixelEncoder expects [..., {self.in_channels}, H, W] channel-first pixels, "
                f"got shape {tuple(pixels.shape)}."
            )
        lead = pixels.shape[:-3]
        h = self.forward_conv(pixels.reshape(-1, *pixels.shape[-3:]))
        out = torch.tanh(self.norm(self.linear(h.flatten(1))))
        return out.reshape(*lead, self.feature_dim)


class FlatEncoder(nn.Module):
    """The encoder role for flat state vectors: identity, or an MLP if ``hidden_dims`` is given.

    Args:
        in_features (int): observation size.

    Keyword Args:
        hidden_dims (sequence of int): hidden layer sizes (ReLU); ``()`` for the identity.
        feature_dim (int, optional): output size with an MLP; defaults to ``in_features``.

    Examples:
        >>> FlatEncoder(5)(torch.ones(3, 5)).shape
        torch.Size([3, 5])
        >>> FlatEncoder(5, hidden_dims=(64,), feature_dim=16)(torch.ones(3, 5)).shape
        torch.Size([3, 16])
    """

    def __init__(self, in_features: int, *, hidden_dims: Sequence[int] = (), feature_dim: int | None = None):
        super().__init__()
        hidden_dims = tuple(hidden_dims)
        if not hidden_dims:
            if feature_dim not in (None, in_features):
                raise ValueError("an identity FlatEncoder keeps in_features; give hidden_dims to change the size.")
            self.net: nn.Module = nn.Identity()
            self.feature_dim = in_features
        else:
            self.feature_dim = in_features if feature_dim is None else feature_dim
            layers: list[nn.Module] = []
            width = in_features
            for h in hidden_dims:
                layers += [nn.Linear(width, h), nn.ReLU(inplace=True)]
                width = h
            layers.append(nn.Linear(width, self.feature_dim))
            self.net = nn.Sequential(*layers)
            self.net.apply(orthogonal_init)

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        return self.net(observation.float())


class TanhGaussianHead(nn.Module):
    """SAC actor MLP: embedding -> ``(loc, scale)`` of a tanh-Gaussian, DrQ's bounded log-std.

    ``log_std = low + (high - low) * (tanh(raw) + 1) / 2`` with ``(low, high) = log_std_bounds``.

    Args:
        feature_dim (int): embedding size.
        action_dim (int): action size.

    Keyword Args:
        hidden_dim (int): hidden units. Defaults to ``1024``.
        hidden_depth (int): hidden layers. Defaults to ``2`` (a 3-layer MLP).
        log_std_bounds (tuple of float): defaults to ``(-10.0, 2.0)`` (DrQ ``config.yaml``).

    Examples:
        >>> loc, scale = TanhGaussianHead(50, 6)(torch.zeros(4, 50))
        >>> loc.shape, bool((scale > 0).all())
        (torch.Size([4, 6]), True)
    """

    def __init__(
        self,
        feature_dim: int,
        action_dim: int,
        *,
        hidden_dim: int = 1024,
        hidden_depth: int = 2,
        log_std_bounds: tuple[float, float] = (-10.0, 2.0),
    ):
        super().__init__()
        low, high = log_std_bounds
        if not low < high:
            raise ValueError(f"log_std_bounds must be increasing, got {log_std_bounds}.")
        self.trunk = mlp(feature_dim, hidden_dim, 2 * action_dim, hidden_depth)
        self.log_std_bounds = (float(low), float(high))

    def forward(self, embedding: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        loc, raw = self.trunk(embedding).chunk(2, dim=-1)
        low, high = self.log_std_bounds
        log_std = low + 0.5 * (high - low) * (torch.tanh(raw) + 1.0)
        return loc, log_std.exp()


class QHead(nn.Module):
    """Q-network head: ``MLP([embedding, action]) -> [..., 1]``.

    Args:
        feature_dim (int): embedding size.
        action_dim (int): action size.

    Keyword Args:
        hidden_dim (int): hidden units. Defaults to ``1024``.
        hidden_depth (int): hidden layers. Defaults to ``2`` (a 3-layer MLP).

    The embedding may have fewer leading dimensions than the action (e.g. one embedding per
    state and ``N`` candidate actions, ``[B, F]`` with ``[B, N, A]``): it is broadcast.

    Examples:
        >>> q = QHead(50, 6)
        >>> q(torch.zeros(4, 50), torch.zeros(4, 64, 6)).shape
        torch.Size([4, 64, 1])
    """

    def __init__(self, feature_dim: int, action_dim: int, *, hidden_dim: int = 1024, hidden_depth: int = 2):
        super().__init__()
        self.feature_dim = feature_dim
        self.action_dim = action_dim
        self.trunk = mlp(feature_dim + action_dim, hidden_dim, 1, hidden_depth)

    def forward(self, embedding: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        if embedding.ndim < action.ndim:
            extra = action.ndim - embedding.ndim
            embedding = embedding.reshape(*embedding.shape[:-1], *(1,) * extra, embedding.shape[-1])
            embedding = embedding.expand(*action.shape[:-1], embedding.shape[-1])
        return self.trunk(torch.cat([embedding, action.to(embedding.dtype)], dim=-1))


def make_encoder(
    observation_shape: Sequence[int],
    *,
    in_key: NestedKey | None = None,
    out_key: NestedKey = "embedding",
    feature_dim: int = 50,
    hidden_dims: Sequence[int] = (),
    channels_last: bool = True,
    compile: bool = False,
) -> TensorDictModule:
    """The encoder as a TensorDictModule: a :class:`PixelEncoder` for ``[C, H, W]`` observations,
    a :class:`FlatEncoder` for ``[D]`` vectors.

    Args:
        observation_shape (sequence of int): one observation's shape (no batch dims).

    Keyword Args:
        in_key (NestedKey): observation entry; ``"pixels"`` for images, ``"observation"`` for
            vectors by default.
        out_key (NestedKey): embedding entry. Defaults to ``"embedding"``.
        feature_dim (int): pixel embedding size (DrQ: 50); for vectors, the MLP output size.
        hidden_dims (sequence of int): vectors only: MLP hidden sizes, ``()`` for the identity.
        channels_last, compile (bool): images only, see :class:`PixelEncoder`.

    The module's ``feature_dim`` attribute gives the embedding size.

    Examples:
        >>> enc = make_encoder((9, 84, 84))
        >>> enc.in_keys, enc.out_keys, enc.feature_dim
        (['pixels'], ['embedding'], 50)
        >>> make_encoder((5,)).feature_dim
        5
    """
    shape = tuple(observation_shape)
    if len(shape) == 3:
        if shape[1] != shape[2]:
            raise ValueError(f"PixelEncoder needs square images, got shape {shape}.")
        net: nn.Module = PixelEncoder(
            shape[0], image_size=shape[1], feature_dim=feature_dim, channels_last=channels_last, compile=compile
        )
        in_key = "pixels" if in_key is None else in_key
    elif len(shape) == 1:
        net = FlatEncoder(shape[0], hidden_dims=hidden_dims, feature_dim=feature_dim if hidden_dims else None)
        in_key = "observation" if in_key is None else in_key
    else:
        raise ValueError(f"observation_shape must be [C, H, W] (pixels) or [D] (states), got {shape}.")
    module = TensorDictModule(net, in_keys=[in_key], out_keys=[out_key])
    module.feature_dim = net.feature_dim
    return module


def action_bounds(action_spec: TensorSpec) -> tuple[torch.Tensor, torch.Tensor]:
    """``(low, high)`` of a bounded action spec, in the default float dtype (DM Control's specs
    are float64; the networks compute in float32)."""
    if not isinstance(action_spec, Bounded):
        raise TypeError(f"a Bounded action spec is needed, got {type(action_spec).__name__}.")
    dtype = torch.get_default_dtype()
    return action_spec.space.low.to(dtype), action_spec.space.high.to(dtype)


def make_sac_actor(
    action_spec: TensorSpec,
    feature_dim: int,
    *,
    in_key: NestedKey = "embedding",
    hidden_dim: int = 1024,
    hidden_depth: int = 2,
    log_std_bounds: tuple[float, float] = (-10.0, 2.0),
) -> ProbabilisticActor:
    """The SAC actor on embeddings: :class:`TanhGaussianHead` + TorchRL's ``TanhNormal``.

    Writes ``"loc"``, ``"scale"`` and ``"action"``; the deterministic action (evaluation) is
    ``tanh(loc)`` rescaled to the spec's bounds, as DrQ's ``dist.mean``.

    Args:
        action_spec (Bounded): the env's action spec.
        feature_dim (int): embedding size (``encoder.feature_dim``).

    Keyword Args:
        in_key (NestedKey): embedding entry. Defaults to ``"embedding"``.
        hidden_dim, hidden_depth, log_std_bounds: see :class:`TanhGaussianHead`.

    Examples:
        >>> from torchrl.data import Bounded
        >>> from tensordict import TensorDict
        >>> spec = Bounded(-1.0, 1.0, shape=(6,))
        >>> actor = make_sac_actor(spec, 50)
        >>> actor(TensorDict({"embedding": torch.zeros(4, 50)}, [4]))["action"].shape
        torch.Size([4, 6])
    """
    low, high = action_bounds(action_spec)
    head = TanhGaussianHead(
        feature_dim, action_spec.shape[-1], hidden_dim=hidden_dim, hidden_depth=hidden_depth, log_std_bounds=log_std_bounds
    )
    module = TensorDictModule(head, in_keys=[in_key], out_keys=["loc", "scale"])
    return ProbabilisticActor(
        module,
        in_keys=["loc", "scale"],
        spec=action_spec,
        distribution_class=TanhNormal,
        distribution_kwargs={"low": low, "high": high},
    )


def make_critic(
    action_spec: TensorSpec,
    feature_dim: int,
    *,
    in_key: NestedKey = "embedding",
    hidden_dim: int = 1024,
    hidden_depth: int = 2,
) -> ValueOperator:
    """One Q head on embeddings, as a ``ValueOperator`` writing ``"state_action_value"``.

    SAC's twin critics (and QT-Opt's twin Q-functions) are two independently initialised
    heads: pass ``[make_critic(...), make_critic(...)]`` to the loss (a single module would be
    copied by TorchRL with re-sampled, not orthogonal, weights).

    Args:
        action_spec (Bounded): the env's action spec.
        feature_dim (int): embedding size.

    Keyword Args:
        in_key (NestedKey): embedding entry. Defaults to ``"embedding"``.
        hidden_dim, hidden_depth: see :class:`QHead`.

    Examples:
        >>> from torchrl.data import Bounded
        >>> from tensordict import TensorDict
        >>> critic = make_critic(Bounded(-1.0, 1.0, shape=(6,)), 50)
        >>> data = TensorDict({"embedding": torch.zeros(4, 50), "action": torch.zeros(4, 6)}, [4])
        >>> critic(data)["state_action_value"].shape
        torch.Size([4, 1])
    """
    head = QHead(feature_dim, action_spec.shape[-1], hidden_dim=hidden_dim, hidden_depth=hidden_depth)
    return ValueOperator(head, in_keys=[in_key, "action"])
