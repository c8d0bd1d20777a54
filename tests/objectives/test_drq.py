"""DrQEncoding, shared by both losses: the bootstrapped target reads the target encoder only."""
import pytest
import torch
from torchrl.objectives import SoftUpdate

from dcs_torchrl.modules import make_critic, make_encoder, make_sac_actor
from dcs_torchrl.objectives import DrQSACLoss, QTOptLoss

HIDDEN = 32


def _sac(action_spec, encoder):
    actor = make_sac_actor(action_spec, encoder.feature_dim, hidden_dim=HIDDEN)
    return DrQSACLoss(actor, [make_critic(action_spec, encoder.feature_dim, hidden_dim=HIDDEN) for _ in range(2)], encoder=encoder)


def _qtopt(action_spec, encoder):
    heads = [make_critic(action_spec, encoder.feature_dim, hidden_dim=HIDDEN) for _ in range(2)]
    return QTOptLoss(heads, encoder=encoder, action_spec=action_spec)


@pytest.mark.parametrize("build", [_sac, _qtopt], ids=["sac", "qtopt"])
def test_the_target_is_unchanged_when_the_online_encoder_changes(action_spec, make_batch, build):
    """The target embedding (both losses) and QT-Opt's target value (SAC's also reads the online
    encoder, through the actor's next action) stay put while the online encoder moves, as between
    two soft updates; the online embedding does move."""
    torch.manual_seed(0)
    loss = build(action_spec, make_encoder((9, 84, 84)))
    SoftUpdate(loss, tau=0.01)  # never stepped: the target copies stay as built
    data = make_batch(4, pixels=True)

    def encode_and_target():
        torch.manual_seed(1)  # the same CEM and actor samples each time
        _, embedding, _, target_embedding = loss._encode(data.clone(), online_next=False)
        return embedding, target_embedding, loss(data.clone())["target_value"]

    embedding, target_embedding, target = encode_and_target()
    with torch.no_grad():
        for param in loss.encoder_network_params.values(True, True):
            param.add_(torch.randn_like(param))
    moved, target_embedding_after, target_after = encode_and_target()
    assert not torch.allclose(moved, embedding)
    assert torch.equal(target_embedding_after, target_embedding)
    if build is _qtopt:
        assert torch.equal(target_after, target)
