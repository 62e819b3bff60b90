"""As SB3's tests/test_custom_policy.py: every ``net_arch`` format SB3 accepts, with and without a value baseline."""

import contextlib
import warnings

import pytest
import torch as th

from sb3_reinforce import REINFORCE


def hidden_sizes(net: th.nn.Module) -> list[int]:
    return [layer.out_features for layer in net.modules() if isinstance(layer, th.nn.Linear)]


@pytest.mark.parametrize("baseline", [None, "value"])
@pytest.mark.parametrize(
    "net_arch, pi, vf",
    [
        ([], [], []),
        ([4], [4], [4]),
        ([4, 4], [4, 4], [4, 4]),
        (dict(vf=[16], pi=[8]), [8], [16]),
        (dict(vf=[8, 4], pi=[8]), [8], [8, 4]),
        (dict(pi=[8]), [8], []),
        # SB3's old format, converted by SB3 with a warning
        ([dict(vf=[8])], [], [8]),
        ([dict(vf=[8], pi=[4])], [4], [8]),
    ],
)
def test_flexible_mlp(tmp_path, net_arch: list | dict, pi: list[int], vf: list[int], baseline: str | None) -> None:
    old_format = isinstance(net_arch, list) and len(net_arch) > 0 and isinstance(net_arch[0], dict)
    expect_warning = pytest.warns(UserWarning, match=r"net_arch=dict\(pi=\.\.\., vf=\.\.\.\)")
    with expect_warning if old_format else contextlib.nullcontext():
        model = REINFORCE("MlpPolicy", "CartPole-v1", baseline=baseline, min_steps=64, policy_kwargs=dict(net_arch=net_arch))
    policy = model.policy
    assert hidden_sizes(policy.mlp_extractor.policy_net) == pi
    if baseline is None:  # no critic at all: no value layers, no value head
        assert hidden_sizes(policy.mlp_extractor.value_net) == [] and not hasattr(policy, "value_net")
    else:
        assert hidden_sizes(policy.mlp_extractor.value_net) == vf
    model.learn(128)
    # The saved architecture is the converted one: loading does not warn again
    model.save(tmp_path / "model.zip")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        loaded = REINFORCE.load(tmp_path / "model.zip")
    assert hidden_sizes(loaded.policy.mlp_extractor.policy_net) == pi
