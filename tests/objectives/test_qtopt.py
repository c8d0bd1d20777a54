"""QTOptLoss: plain QT-Opt at K = M = 0, the DrQ target and loss, clipped double Q, training."""
import math

import pytest
import torch
import torch.nn.functional as F
from torchrl.data import Unbounded
from torchrl.objectives import SoftUpdate

from dcs_torchrl.modules import ObservationNoise, RandomShift, make_critic, make_encoder, with_next_keys
from dcs_torchrl.objectives import QTOptLoss, averaged_cross_entropy, cem_maximize

HIDDEN = 32


def _loss(action_spec, *, pixels=False, copies=0, augmentation=None, seed=0, **kwargs):
    torch.manual_seed(seed)
    encoder = make_encoder((9, 84, 84) if pixels else (5,))
    heads = [make_critic(action_spec, encoder.feature_dim, hidden_dim=HIDDEN) for _ in range(2)]
    loss = QTOptLoss(
        heads, encoder=encoder, action_spec=action_spec, augmentation=augmentation,
        num_augmentations=copies, **kwargs,
    )
    SoftUpdate(loss, tau=0.01)
    return loss


def _heads(loss, params, embedding, action):
    net = loss.qvalue_network
    outs = []
    for i in range(loss.num_qvalue_nets):
        with params[i].to_module(net):
            outs.append(net.module(embedding, action).squeeze(-1))
    return torch.stack(outs)


def test_plain_qtopt_is_binary_cross_entropy_on_the_cem_target(action_spec, make_batch):
    loss = _loss(action_spec, reward_range=(0.0, 2.0))
    data = make_batch(6, pixels=False)
    torch.manual_seed(1)
    out = loss(data.clone())
    torch.manual_seed(1)  # K = 0 draws no augmentation noise: the CEM sees the same random numbers
    with torch.no_grad():
        next_value = loss.next_state_value(data["next", "observation"].float())
    v_min, v_max = 0.0, 2.0 / (1 - 0.99)
    assert loss.value_bounds() == pytest.approx((v_min, v_max))
    y = data["next", "reward"].squeeze(-1) + 0.99 * next_value
    t = (y - v_min) / (v_max - v_min)
    logits = _heads(loss, loss.qvalue_network_params, data["observation"], data["action"]) + math.log(0.01 / 0.99)
    expected = F.binary_cross_entropy_with_logits(logits, t.expand_as(logits), reduction="none").sum(0).mean()
    torch.testing.assert_close(out["loss_qvalue"], expected, rtol=1e-5, atol=1e-6)
    torch.testing.assert_close(out["target_value"], y.mean(), rtol=1e-5, atol=1e-5)


def test_clipped_double_q_target(action_spec, make_batch):
    """V(s') = min_i Q_target_i(s', a*), a* = CEM argmax of the first target head."""
    loss = _loss(action_spec)
    emb = make_batch(16, pixels=False)["next", "observation"]
    with torch.no_grad():
        # make the second target head the first one minus 2 logits: the min is the second
        loss.target_qvalue_network_params[1].update_(loss.target_qvalue_network_params[0])
        final_bias = [k for k in loss.target_qvalue_network_params.keys(True, True) if k[-1] == "bias"][-1]
        loss.target_qvalue_network_params[final_bias][1] -= 2.0
        torch.manual_seed(2)
        value = loss.next_state_value(emb)
        torch.manual_seed(2)
        with loss.target_qvalue_network_params[0].to_module(loss.qvalue_network):
            _, best_logit = cem_maximize(
                lambda a: loss.qvalue_network.module(emb, a), [16], loss.action_low, loss.action_high
            )
    v_min, v_max = loss.value_bounds()
    expected = v_min + (v_max - v_min) * torch.sigmoid(best_logit - 2.0 + math.log(0.01 / 0.99))
    torch.testing.assert_close(value, expected, rtol=1e-5, atol=1e-4)
    # and the target uses the target parameters, not the online ones
    with torch.no_grad():
        for p in loss.qvalue_network_params.values(True, True):
            p.add_(1.0)
        torch.manual_seed(2)
        torch.testing.assert_close(loss.next_state_value(emb), value)


def test_drq_target_and_loss_average_over_the_copies(action_spec, make_batch):
    """K = M = 2: y = r + gamma (1/K) sum_k V(f(s', nu_k)); J = sum_i CE(y, (1/M) sum_m Q_i(f(s, nu_m), a))."""
    std, copies = 0.3, 2
    loss = _loss(
        action_spec, copies=copies,
        augmentation=ObservationNoise(std, in_keys=with_next_keys(["observation"]), generator=torch.Generator().manual_seed(3)),
    )
    data = make_batch(5, pixels=False)
    torch.manual_seed(4)
    out = loss(data.clone())

    replay = torch.Generator().manual_seed(3)
    obs = data["observation"] + std * torch.randn(copies, 5, 5, generator=replay)
    next_obs = data["next", "observation"] + std * torch.randn(copies, 5, 5, generator=replay)
    torch.manual_seed(4)
    with torch.no_grad():
        value = loss.next_state_value(next_obs)  # [K, B]
    y = data["next", "reward"].squeeze(-1) + 0.99 * value.mean(0)
    v_min, v_max = loss.value_bounds()
    t = (y - v_min) / (v_max - v_min)
    logits = _heads(loss, loss.qvalue_network_params, obs, data["action"].expand(copies, 5, 2)) + math.log(0.01 / 0.99)
    p_mean = torch.sigmoid(logits).mean(1)  # [heads, B]: the mean over the M copies
    expected = (-(t * p_mean.log() + (1 - t) * (1 - p_mean).log())).sum(0).mean()
    torch.testing.assert_close(out["loss_qvalue"], expected, rtol=1e-5, atol=1e-6)
    torch.testing.assert_close(out["target_value"], y.mean(), rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("copies", [0, 2])
def test_a_time_limit_keeps_the_bootstrap_and_a_termination_drops_it(action_spec, make_batch, copies):
    """done without terminated (every DM Control episode end: a time limit) still bootstraps,
    y = r + gamma V(s'); terminated stops it, y = r."""
    augmentation = ObservationNoise(0.1, in_keys=with_next_keys(["observation"])) if copies else None
    loss = _loss(action_spec, copies=copies, augmentation=augmentation)
    data = make_batch(6, pixels=False)

    def run(done, terminated):
        batch = data.clone()
        batch["next", "done"].fill_(done)
        batch["next", "terminated"].fill_(terminated)
        torch.manual_seed(7)  # the same CEM samples (and augmentations) in every call
        return loss(batch)

    running, time_limit, terminal = run(False, False), run(True, False), run(True, True)
    reward = data["next", "reward"].mean()
    torch.testing.assert_close(terminal["target_value"], reward)  # nothing after a termination
    for key in ("target_value", "loss_qvalue"):  # a time limit changes nothing
        torch.testing.assert_close(time_limit[key], running[key], rtol=0, atol=0)
    next_value = time_limit["next_state_value"]
    assert next_value > 0.1  # values start near 1% of [0, 100]: the bootstrap is visible
    torch.testing.assert_close(time_limit["target_value"], reward + 0.99 * next_value)


def test_one_identity_copy_is_exactly_no_augmentation(action_spec, make_batch):
    data = make_batch(4, pixels=True)
    plain = _loss(action_spec, pixels=True)
    one = _loss(action_spec, pixels=True, copies=1, augmentation=RandomShift(0, in_keys=with_next_keys(["pixels"])))
    torch.manual_seed(5)
    a = plain(data.clone())
    torch.manual_seed(5)
    b = one(data.clone())
    for key in a.keys():
        assert torch.equal(a[key], b[key]), key


def test_averaged_cross_entropy_is_stable_and_exact():
    logits = torch.tensor([[40.0, -40.0, 0.3], [39.0, -45.0, -1.2]])
    t = torch.tensor([1.0, 0.0, 0.6])
    loss, p = averaged_cross_entropy(logits, t, dim=0)
    assert torch.isfinite(loss).all()
    single, _ = averaged_cross_entropy(logits[:1], t, dim=0)
    torch.testing.assert_close(single, F.binary_cross_entropy_with_logits(logits[0], t, reduction="none"))
    naive = -(t * p.log() + (1 - t) * (1 - p).log())
    torch.testing.assert_close(loss[2], naive[2])


@pytest.mark.parametrize("loss_function", ["cross_entropy", "l2"])
def test_loss_decreases_on_a_fixed_batch_and_trains_the_encoder(action_spec, make_batch, loss_function):
    loss = _loss(
        action_spec, pixels=True, copies=2, augmentation=RandomShift(4, in_keys=with_next_keys(["pixels"])),
        loss_function=loss_function, cem_samples=16, cem_elites=4,
    )
    optim = torch.optim.Adam(loss.parameters(), lr=1e-3)
    data = make_batch(8, pixels=True)
    torch.manual_seed(6)
    history = []
    for step in range(30):
        out = loss(data.clone())
        history.append(out["loss_qvalue"].item())
        optim.zero_grad()
        out["loss_qvalue"].backward()
        if step == 0:
            assert all(p.grad.abs().sum() > 0 for p in loss.encoder_network_params.values(True, True))
        optim.step()
    if loss_function == "cross_entropy":  # CE has a floor: the entropy of the normalised target
        assert sum(history[-5:]) / 5 < history[0]
    else:
        assert sum(history[-5:]) / 5 < 0.5 * history[0]


def test_state_dict_round_trip_and_priority(action_spec, make_batch):
    data = make_batch(4, pixels=False)
    trained, fresh = _loss(action_spec, seed=0), _loss(action_spec, seed=1)
    torch.manual_seed(7)
    expected = trained(data.clone())
    fresh.load_state_dict(trained.state_dict())
    out_data = data.clone()
    torch.manual_seed(7)
    assert torch.equal(fresh(out_data)["loss_qvalue"], expected["loss_qvalue"])
    assert out_data["td_error"].shape == (4,)


def test_configuration_errors(action_spec):
    encoder = make_encoder((5,))
    heads = [make_critic(action_spec, 5, hidden_dim=HIDDEN) for _ in range(2)]
    with pytest.raises(ValueError, match="loss_function must be one of"):
        QTOptLoss(heads, encoder=encoder, action_spec=action_spec, loss_function="huber")
    with pytest.raises(ValueError, match="reward_range must be increasing"):
        QTOptLoss(heads, encoder=encoder, action_spec=action_spec, reward_range=(1.0, 0.0))
    with pytest.raises(ValueError, match="initial_value is a fraction"):
        QTOptLoss(heads, encoder=encoder, action_spec=action_spec, initial_value=0.0)
    with pytest.raises(TypeError, match="Bounded action spec"):
        QTOptLoss(heads, encoder=encoder, action_spec=Unbounded(shape=(2,)))
    with pytest.raises(ValueError, match="got 2 Q heads for num_qvalue_nets=3"):
        QTOptLoss(heads, encoder=encoder, action_spec=action_spec, num_qvalue_nets=3)
