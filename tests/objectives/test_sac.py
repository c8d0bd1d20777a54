"""DrQSACLoss: the K = M knob, the shared encoder's gradients, the DrQ target, training on a batch."""
import pytest
import torch
from tensordict import TensorDict
from torchrl.objectives import SACLoss, SoftUpdate

from dcs_torchrl.modules import (
    ObservationNoise,
    RandomShift,
    make_critic,
    make_encoder,
    make_sac_actor,
    with_next_keys,
)
from dcs_torchrl.objectives import DrQSACLoss

HIDDEN = 32


def _modules(action_spec, *, pixels: bool, seed: int = 0, log_std_bounds=(-10.0, 2.0)):
    torch.manual_seed(seed)
    encoder = make_encoder((9, 84, 84) if pixels else (5,))
    actor = make_sac_actor(action_spec, encoder.feature_dim, hidden_dim=HIDDEN, log_std_bounds=log_std_bounds)
    critics = [make_critic(action_spec, encoder.feature_dim, hidden_dim=HIDDEN) for _ in range(2)]
    return encoder, actor, critics


def _loss(action_spec, *, pixels=True, copies=0, augmentation=None, seed=0, **kwargs):
    encoder, actor, critics = _modules(action_spec, pixels=pixels, seed=seed, **kwargs.pop("modules", {}))
    loss = DrQSACLoss(actor, critics, encoder=encoder, augmentation=augmentation, num_augmentations=copies, **kwargs)
    SoftUpdate(loss, tau=0.01)
    return loss


def _grads(params):
    return {k: (None if v.grad is None else v.grad.clone()) for k, v in params.items(True, True)}


def test_no_augmentation_is_exactly_torchrl_sac_loss(action_spec, make_batch):
    """K = M = 0: the same numbers and gradients as TorchRL's SACLoss run on the encoder's output."""
    encoder, actor, critics = _modules(action_spec, pixels=True)
    ours = DrQSACLoss(actor, critics, encoder=encoder)
    reference = SACLoss(actor, critics, loss_function="l2", alpha_init=0.1)
    SoftUpdate(ours, tau=0.01)
    SoftUpdate(reference, tau=0.01)
    data = make_batch(6, pixels=True)

    torch.manual_seed(1)
    out = ours(data.clone())
    out["loss_qvalue"].backward()
    ours_q_grads = _grads(ours.qvalue_network_params)
    ours_enc_grads = _grads(ours.encoder_network_params)
    encoder.zero_grad()

    ref_data = data.clone()
    ref_data["embedding"] = encoder(data.select("pixels").clone())["embedding"]
    with torch.no_grad():  # the target encoder equals the online one before any update
        ref_data["next", "embedding"] = encoder(data["next"].select("pixels").clone())["embedding"]
    torch.manual_seed(1)
    ref = reference(ref_data)
    ref["loss_qvalue"].backward()

    for key in ("loss_qvalue", "loss_actor", "loss_alpha", "alpha", "entropy"):
        torch.testing.assert_close(out[key], ref[key], rtol=1e-6, atol=1e-6)
    for key, grad in _grads(reference.qvalue_network_params).items():
        torch.testing.assert_close(ours_q_grads[key], grad, rtol=1e-5, atol=1e-7)
    for key, param in ours.encoder_network_params.items(True, True):
        torch.testing.assert_close(ours_enc_grads[key], param.grad, rtol=1e-5, atol=1e-7)


def test_one_identity_copy_is_exactly_no_augmentation(action_spec, make_batch):
    """K = M = 1 with an identity augmentation (a zero shift) is bit-for-bit the K = M = 0 loss."""
    data = make_batch(4, pixels=True)
    plain = _loss(action_spec)
    one = _loss(action_spec, copies=1, augmentation=RandomShift(0, in_keys=with_next_keys(["pixels"])))
    torch.manual_seed(2)
    a = plain(data.clone())
    torch.manual_seed(2)
    b = one(data.clone())
    for key in ("loss_qvalue", "loss_actor", "loss_alpha", "target_value"):
        assert torch.equal(a[key], b[key]), key


def test_drq_target_and_loss_average_over_the_copies(action_spec, make_batch):
    """K = M = 2: y = r + gamma (1/K) sum_k V(f(s', nu_k)), loss = (1/M) sum_m sum_i (Q_i(f(s, nu_m), a) - y)^2."""
    std, copies = 0.3, 2
    gen = torch.Generator().manual_seed(3)
    # a near-deterministic actor (tiny std) and temperature make V deterministic
    loss = _loss(
        action_spec, pixels=False, copies=copies, fixed_alpha=True, alpha_init=1e-9,
        augmentation=ObservationNoise(std, in_keys=with_next_keys(["observation"]), generator=gen),
        modules={"log_std_bounds": (-20.0, -19.9)},
    )
    data = make_batch(5, pixels=False)
    out = loss(data.clone())

    replay = torch.Generator().manual_seed(3)
    obs_noise = torch.randn(copies, 5, 5, generator=replay)  # drawn for "observation" first,
    next_noise = torch.randn(copies, 5, 5, generator=replay)  # then for ("next", "observation")
    obs = data["observation"] + std * obs_noise
    next_obs = data["next", "observation"] + std * next_noise
    with torch.no_grad():
        loc, _ = loss.actor_network.module[0].module(next_obs)
        next_action = torch.tanh(loc)
        net = loss.qvalue_network
        q_next = []
        for i in range(2):
            with loss.target_qvalue_network_params[i].to_module(net):
                q_next.append(net.module(next_obs, next_action))
        value = torch.stack(q_next).min(0).values  # [K, B, 1]
        y = data["next", "reward"] + 0.99 * value.mean(0)  # [B, 1]
        sq = []
        for i in range(2):
            with loss.qvalue_network_params[i].to_module(net):
                sq.append((net.module(obs, data["action"].expand(copies, 5, 2)) - y) ** 2)
        expected = torch.stack(sq).sum(0).mean()  # sum over critics, mean over copies and batch
    torch.testing.assert_close(out["target_value"], y.mean(), rtol=1e-4, atol=1e-4)
    torch.testing.assert_close(out["loss_qvalue"], expected, rtol=1e-4, atol=1e-4)


def test_encoder_is_trained_by_the_critic_loss_only(action_spec, make_batch):
    loss = _loss(action_spec, copies=2, augmentation=RandomShift(4, in_keys=with_next_keys(["pixels"])))
    out = loss(make_batch(4, pixels=True))
    (out["loss_actor"] + out["loss_alpha"]).backward(retain_graph=True)
    assert all(p.grad is None for p in loss.encoder_network_params.values(True, True))
    assert all(p.grad is None for p in loss.qvalue_network_params.values(True, True))
    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in loss.actor_network_params.values(True, True))
    assert loss.log_alpha.grad is not None
    for p in loss.actor_network_params.values(True, True):
        p.grad = None
    out["loss_qvalue"].backward()
    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in loss.encoder_network_params.values(True, True))
    assert all(p.grad is None for p in loss.actor_network_params.values(True, True))


@pytest.mark.parametrize("aug", ["none", "drq"])
def test_losses_decrease_on_a_fixed_batch(action_spec, make_batch, aug):
    copies = {"none": 0, "drq": 2}[aug]
    augmentation = RandomShift(4, in_keys=with_next_keys(["pixels"])) if copies else None
    # a near-deterministic actor and fixed small temperature: the target noise is the augmentation's only
    loss = _loss(
        action_spec, copies=copies, augmentation=augmentation, fixed_alpha=True, alpha_init=1e-6,
        modules={"log_std_bounds": (-20.0, -19.9)},
    )
    critic = torch.optim.Adam([*loss.qvalue_network_params.values(True, True), *loss.encoder_network_params.values(True, True)], lr=1e-3)
    actor = torch.optim.Adam(loss.actor_network_params.values(True, True), lr=1e-3)
    data = make_batch(8, pixels=True)
    torch.manual_seed(4)
    history = []
    for _ in range(30):
        out = loss(data.clone())
        history.append(out.detach())
        critic.zero_grad()
        actor.zero_grad()
        (out["loss_qvalue"] + out["loss_actor"]).backward()
        critic.step()
        actor.step()
    first, last = history[0], torch.stack(history[-5:]).mean()
    assert last["loss_qvalue"] < 0.5 * first["loss_qvalue"]
    assert last["loss_actor"] < first["loss_actor"]


def test_soft_update_moves_target_encoder_and_critics(action_spec):
    loss = DrQSACLoss(*_modules(action_spec, pixels=True)[1:], encoder=_modules(action_spec, pixels=True)[0])
    updater = SoftUpdate(loss, tau=0.1)
    targets_before = loss.target_encoder_network_params.clone()
    q_targets_before = loss.target_qvalue_network_params.clone()
    with torch.no_grad():
        for p in (*loss.encoder_network_params.values(True, True), *loss.qvalue_network_params.values(True, True)):
            p.add_(1.0)
    updater.step()
    expected = 0.9 * targets_before + 0.1 * loss.encoder_network_params.data
    torch.testing.assert_close(loss.target_encoder_network_params.data, expected)
    torch.testing.assert_close(
        loss.target_qvalue_network_params.data, 0.9 * q_targets_before + 0.1 * loss.qvalue_network_params.data
    )


def test_state_dict_round_trip_and_priority(action_spec, make_batch):
    data = make_batch(4, pixels=True)
    trained = _loss(action_spec, seed=0)
    fresh = _loss(action_spec, seed=1)
    torch.manual_seed(5)
    expected = trained(data.clone())
    fresh.load_state_dict(trained.state_dict())
    out_data = data.clone()
    torch.manual_seed(5)
    got = fresh(out_data)
    for key in ("loss_qvalue", "loss_actor", "loss_alpha"):
        assert torch.equal(expected[key], got[key]), key
    assert out_data["td_error"].shape == (4,)


def test_configuration_errors(action_spec):
    encoder, actor, critics = _modules(action_spec, pixels=True)
    with pytest.raises(ValueError, match="needs an augmentation transform"):
        DrQSACLoss(actor, critics, encoder=encoder, num_augmentations=2)
    with pytest.raises(ValueError, match="pass augmentation=None"):
        DrQSACLoss(actor, critics, encoder=encoder, augmentation=RandomShift(4))
    with pytest.raises(ValueError, match=r"missing \[\('next', 'pixels'\)\]"):
        DrQSACLoss(actor, critics, encoder=encoder, num_augmentations=2, augmentation=RandomShift(4))
    with pytest.raises(ValueError, match="integer >= 0"):
        DrQSACLoss(actor, critics, encoder=encoder, num_augmentations=-1)
    with pytest.raises(ValueError, match="reduction must be"):
        DrQSACLoss(actor, critics, encoder=encoder, reduction="none")
    pixel_critics = [make_critic(action_spec, 50, in_key="pixels") for _ in range(2)]
    with pytest.raises(ValueError, match="must read the encoder's output 'embedding'"):
        DrQSACLoss(actor, pixel_critics, encoder=encoder)


def _with_ends(data, done: bool, terminated: bool):
    batch = data.clone()
    batch["next", "done"].fill_(done)
    batch["next", "terminated"].fill_(terminated)
    return batch


@pytest.mark.parametrize("copies", [0, 2])
def test_a_time_limit_keeps_the_bootstrap_and_a_termination_drops_it(action_spec, make_batch, copies):
    """done without terminated (every DM Control episode end: a time limit) still bootstraps,
    y = r + gamma V(s'); terminated stops it, y = r."""
    augmentation = ObservationNoise(0.1, in_keys=with_next_keys(["observation"])) if copies else None
    loss = _loss(action_spec, pixels=False, copies=copies, augmentation=augmentation)
    data = make_batch(6, pixels=False)

    def target(done, terminated):
        torch.manual_seed(7)  # the same next actions (and augmentations) in every call
        return loss(_with_ends(data, done, terminated))["target_value"]

    running, time_limit, terminal = target(False, False), target(True, False), target(True, True)
    reward = data["next", "reward"].mean()
    torch.testing.assert_close(terminal, reward)  # nothing after a termination
    torch.testing.assert_close(time_limit, running, rtol=0, atol=0)  # a time limit changes nothing
    assert (time_limit - reward).abs() > 1e-2  # ... and the discounted next value is in the target


def test_in_keys_are_the_encoder_inputs(action_spec):
    loss = _loss(action_spec)
    assert set(loss.in_keys) == {
        "action", "pixels", ("next", "pixels"), ("next", "reward"), ("next", "done"), ("next", "terminated")
    }


def test_a_terminal_batch_regresses_the_critics_on_the_reward(action_spec):
    """Every transition terminated: y = r exactly, and loss_qvalue = sum_i mean (Q_i(s, a) - r)^2."""
    loss = _loss(action_spec)
    gen = torch.Generator().manual_seed(8)
    data = TensorDict(
        {
            "pixels": torch.randint(0, 256, (3, 9, 84, 84), generator=gen).to(torch.uint8),
            "action": 2 * torch.rand(3, 2, generator=gen) - 1,
            ("next", "pixels"): torch.randint(0, 256, (3, 9, 84, 84), generator=gen).to(torch.uint8),
            ("next", "reward"): torch.tensor([[0.5], [2.0], [-1.0]]),
            ("next", "done"): torch.ones(3, 1, dtype=torch.bool),
            ("next", "terminated"): torch.ones(3, 1, dtype=torch.bool),
        },
        [3],
    )
    out = loss(data.clone())
    with torch.no_grad(), loss.encoder_network_params.to_module(loss.encoder_network):
        embedding = loss.encoder_network(data.select("pixels").clone())["embedding"]
        net, q = loss.qvalue_network, []
        for i in range(2):
            with loss.qvalue_network_params[i].to_module(net):
                q.append(net.module(embedding, data["action"]))
        expected = sum(((qi - data["next", "reward"]) ** 2).mean() for qi in q)
    torch.testing.assert_close(out["target_value"], torch.tensor(0.5))
    torch.testing.assert_close(out["loss_qvalue"], expected, rtol=1e-5, atol=1e-6)
