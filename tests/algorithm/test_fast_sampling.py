"""
The fast rollout sampler draws from the same distributions as SB3's ``get_distribution(obs).get_actions()``.

Chi-square tests for the discrete spaces and Kolmogorov-Smirnov tests for the Gaussian, on tens of thousands
of samples with fixed parameters and fixed seeds (so the tests are deterministic). A wrong distribution
(probabilities taken as logits, a missing ``exp`` on ``log_std``, ...) gives p-values far below the threshold.
"""

import copy
import warnings

import gymnasium as gym
import numpy as np
import pytest
import scipy.special
import torch as th
from gymnasium import spaces
from scipy import stats
from stable_baselines3.common.distributions import Distribution

from sb3_reinforce import REINFORCE
from sb3_reinforce.reinforce.policies import ReinforcePolicy
from sb3_reinforce.reinforce.sampling import FastSampler

N_SAMPLES = 40_000
ALPHA = 1e-3  # fixed seeds: a correct sampler passes with these exact draws, a wrong one fails by far
OBS_SPACE = spaces.Box(-1.0, 1.0, (4,), np.float32)


def make_policy(action_space: spaces.Space, activation_fn: type[th.nn.Module] = th.nn.Tanh) -> ReinforcePolicy:
    th.manual_seed(0)
    policy = ReinforcePolicy(OBS_SPACE, action_space, lambda _: 1e-3, value_head=False, activation_fn=activation_fn)
    with th.no_grad():  # spread the parameters, so that the distribution is far from uniform
        policy.action_net.weight.normal_(0.0, 0.5)
        policy.action_net.bias.copy_(th.linspace(-1.5, 1.5, policy.action_net.bias.numel()))
        if hasattr(policy, "log_std"):
            policy.log_std.copy_(th.linspace(-0.7, 0.4, policy.log_std.numel()))
    return policy


def fast_and_sb3_samples(policy: ReinforcePolicy) -> tuple[np.ndarray, np.ndarray, Distribution, FastSampler]:
    """N_SAMPLES actions for one fixed observation, from the fast sampler and from SB3's path."""
    obs = np.tile(np.array([[0.3, -0.5, 0.8, 0.1]], dtype=np.float32), (N_SAMPLES, 1))
    th.manual_seed(1)  # seeds the sampler's NumPy generator
    sampler = policy.fast_sampler()
    assert sampler is not None
    fast = sampler(obs)
    th.manual_seed(2)
    with th.no_grad():
        distribution = policy.get_distribution(th.as_tensor(obs))
        sb3 = distribution.get_actions().numpy().reshape(fast.shape)
    return fast, sb3, distribution, sampler


def assert_same_categorical(fast: np.ndarray, sb3: np.ndarray, probs: np.ndarray) -> None:
    """Chi-square goodness of fit of both samples to ``probs``, and of the two samples against each other."""
    n = len(probs)
    fast_counts, sb3_counts = np.bincount(fast, minlength=n), np.bincount(sb3, minlength=n)
    assert stats.chisquare(fast_counts, probs * len(fast)).pvalue > ALPHA
    assert stats.chisquare(sb3_counts, probs * len(sb3)).pvalue > ALPHA
    seen = (fast_counts + sb3_counts) > 0
    assert stats.chi2_contingency(np.stack([fast_counts[seen], sb3_counts[seen]])).pvalue > ALPHA


@pytest.mark.parametrize("activation_fn", [th.nn.Tanh, th.nn.ReLU, th.nn.ELU])
def test_discrete(activation_fn: type[th.nn.Module]) -> None:
    policy = make_policy(spaces.Discrete(5), activation_fn)
    fast, sb3, distribution, sampler = fast_and_sb3_samples(policy)
    # Tanh/ReLU run the actor in NumPy, ELU runs the torch modules: both paths are tested.
    assert (sampler.numpy_layers is None) == (activation_fn is th.nn.ELU)
    assert fast.dtype == sb3.dtype == np.int64
    probs = distribution.distribution.probs[0].numpy().astype(np.float64)
    assert probs.max() > 0.4  # far from uniform
    assert_same_categorical(fast, sb3, probs / probs.sum())


def test_multidiscrete() -> None:
    nvec = [3, 4, 2]
    policy = make_policy(spaces.MultiDiscrete(nvec))
    fast, sb3, distribution, _ = fast_and_sb3_samples(policy)
    assert fast.shape == sb3.shape == (N_SAMPLES, 3) and fast.dtype == sb3.dtype
    for dim, categorical in enumerate(distribution.distribution):
        probs = categorical.probs[0].numpy().astype(np.float64)
        assert_same_categorical(fast[:, dim], sb3[:, dim], probs / probs.sum())
    # Joint outcomes: the dimensions are independent in both
    joint_probs = np.einsum("i,j,k->ijk", *[c.probs[0].numpy().astype(np.float64) for c in distribution.distribution])
    joint = np.ravel_multi_index(fast.T, nvec)
    expected = joint_probs.ravel() / joint_probs.sum() * N_SAMPLES
    assert stats.chisquare(np.bincount(joint, minlength=24), expected).pvalue > ALPHA


def test_multibinary() -> None:
    policy = make_policy(spaces.MultiBinary(4))
    fast, sb3, distribution, _ = fast_and_sb3_samples(policy)
    assert fast.shape == sb3.shape == (N_SAMPLES, 4) and fast.dtype == sb3.dtype == np.float32
    assert set(np.unique(fast)) <= {0.0, 1.0}
    p_one = distribution.distribution.probs[0].numpy().astype(np.float64)
    for dim in range(4):
        counts = np.bincount(fast[:, dim].astype(int), minlength=2)
        assert stats.chisquare(counts, [(1 - p_one[dim]) * N_SAMPLES, p_one[dim] * N_SAMPLES]).pvalue > ALPHA


def test_box_gaussian() -> None:
    policy = make_policy(spaces.Box(-2.0, 2.0, (3,), np.float32))
    fast, sb3, distribution, _ = fast_and_sb3_samples(policy)
    assert fast.shape == sb3.shape == (N_SAMPLES, 3) and fast.dtype == sb3.dtype == np.float32
    mean = distribution.distribution.mean[0].numpy()
    std = distribution.distribution.stddev[0].numpy()
    assert len(np.unique(np.round(std, 3))) == 3  # different stds per dimension
    for dim in range(3):
        assert stats.kstest(fast[:, dim], stats.norm(mean[dim], std[dim]).cdf).pvalue > ALPHA
        assert stats.ks_2samp(fast[:, dim], sb3[:, dim]).pvalue > ALPHA


def test_wrong_distribution_is_detected() -> None:
    """The tests above can fail: sampling with a temperature of 2 (logits / 2) is rejected."""
    policy = make_policy(spaces.Discrete(5))
    _, sb3, _, sampler = fast_and_sb3_samples(policy)
    obs = np.tile(np.array([[0.3, -0.5, 0.8, 0.1]], dtype=np.float32), (N_SAMPLES, 1))
    wrong = sampler.sample(sampler.distribution_parameters(obs) / 2)
    counts = np.stack([np.bincount(wrong, minlength=5), np.bincount(sb3, minlength=5)])
    assert stats.chi2_contingency(counts[:, counts.sum(0) > 0]).pvalue < ALPHA


@pytest.mark.parametrize(
    "action_space", [spaces.Discrete(3), spaces.MultiDiscrete([2, 3]), spaces.MultiBinary(2), spaces.Box(-1, 1, (2,))]
)
def test_distribution_parameters_match_sb3(action_space: spaces.Space) -> None:
    """The NumPy forward pass gives SB3's logits / means (up to float32 rounding)."""
    policy = make_policy(action_space)
    obs = np.random.default_rng(0).uniform(-1, 1, (64, 4)).astype(np.float32)
    sampler = policy.fast_sampler()
    assert sampler is not None and sampler.numpy_layers is not None
    with th.no_grad():
        latent = policy.mlp_extractor.forward_actor(policy.extract_features(th.as_tensor(obs), policy.pi_features_extractor))
        expected = policy.action_net(latent).numpy()
    np.testing.assert_allclose(sampler.distribution_parameters(obs), expected, rtol=1e-5, atol=1e-5)


def test_sampler_follows_the_optimizer() -> None:
    """The NumPy layers are views: after an optimizer step the sampler uses the new weights."""
    policy = make_policy(spaces.Discrete(3))
    sampler = policy.fast_sampler()
    assert sampler is not None
    obs = np.ones((2, 4), dtype=np.float32)
    before = sampler.distribution_parameters(obs).copy()
    loss = policy.action_net(policy.mlp_extractor.forward_actor(th.as_tensor(obs))).sum()
    loss.backward()
    policy.optimizer.step()
    after = sampler.distribution_parameters(obs)
    assert not np.allclose(before, after)
    np.testing.assert_allclose(after, policy.fast_sampler().distribution_parameters(obs), rtol=1e-6)  # type: ignore[union-attr]


class OwnDistributionPolicy(ReinforcePolicy):
    def get_distribution(self, obs: th.Tensor) -> Distribution:  # type: ignore[override]
        return super().get_distribution(obs)


def test_fallback_to_sb3_path() -> None:
    box = spaces.Box(-1, 1, (2,))
    assert ReinforcePolicy(OBS_SPACE, box, lambda _: 1e-3, use_sde=True).fast_sampler() is None
    assert ReinforcePolicy(OBS_SPACE, box, lambda _: 1e-3, fast_rollout=False).fast_sampler() is None
    assert OwnDistributionPolicy(OBS_SPACE, box, lambda _: 1e-3).fast_sampler() is None
    assert ReinforcePolicy(OBS_SPACE, box, lambda _: 1e-3).fast_sampler() is not None
    # A Discrete observation (one-hot in torch) runs the torch modules
    sampler = ReinforcePolicy(spaces.Discrete(4), box, lambda _: 1e-3).fast_sampler()
    assert sampler is not None and sampler.numpy_layers is None
    assert sampler(np.array([0, 3])).shape == (2, 2)


@pytest.mark.parametrize("env_id", ["CartPole-v1", "Pendulum-v1"])
def test_loss_and_predict_do_not_depend_on_the_flag(env_id: str) -> None:
    """
    The same batch gives the same gradient step with the fast path on and off (log_prob and entropy in closed
    form, or through SB3's distribution objects), and deterministic ``predict`` is the same.
    """
    fast = REINFORCE("MlpPolicy", env_id, seed=0, device="cpu", min_steps=300)
    slow = REINFORCE("MlpPolicy", env_id, seed=0, device="cpu", min_steps=300, policy_kwargs=dict(fast_rollout=False))
    slow.policy.load_state_dict(fast.policy.state_dict())
    fast.learn(1)  # one rollout with the fast sampler, one gradient step
    assert fast.policy.fast_sampler() is not None and slow.policy.fast_sampler() is None
    # Replay the fast model's batch in the slow model: same starting weights, same update
    slow._setup_learn(1)
    slow.rollout_buffer = copy.deepcopy(fast.rollout_buffer)
    slow.train()
    for a, b in zip(fast.policy.parameters(), slow.policy.parameters(), strict=True):
        th.testing.assert_close(a, b)
    obs = np.stack([gym.make(env_id).observation_space.sample() for _ in range(16)])
    np.testing.assert_array_equal(fast.predict(obs, deterministic=True)[0], slow.predict(obs, deterministic=True)[0])


def test_fast_and_sb3_rollouts_both_learn_a_batch() -> None:
    """Both paths store the same kind of batch (shapes, dtypes, whole episodes)."""
    batches = []
    for fast_rollout in (True, False):
        model = REINFORCE("MlpPolicy", "CartPole-v1", n_episodes=3, seed=0, policy_kwargs=dict(fast_rollout=fast_rollout))
        model.learn(1)
        buffer = model.rollout_buffer
        batches.append({name: (array.shape[1:], array.dtype) for name, array in buffer._batch.items()})
        assert buffer.episode_lengths.sum() == buffer.batch_size
    assert batches[0] == batches[1]


@pytest.mark.parametrize("shape", [(8, 2), (3, 5), (1, 1)])
def test_in_place_noise_is_torchs_stream(shape: tuple[int, int]) -> None:
    # The sampler draws into preallocated tensors: the values must be those of torch's allocating calls
    # (the stream that set_random_seed fixes and save/load restores), draw for draw.
    from sb3_reinforce.reinforce.sampling import _Noise

    noise = _Noise()
    th.manual_seed(1)
    expected = [
        th.empty(shape, dtype=th.float64).exponential_().numpy().copy(),
        th.rand(shape, dtype=th.float64).numpy().copy(),
        th.randn(shape, dtype=th.float64).numpy().copy(),
        th.empty(shape, dtype=th.float64).exponential_().numpy().copy(),
    ]
    th.manual_seed(1)
    drawn = [noise.exponential(shape).copy(), noise.uniform(shape).copy(), noise.normal(shape).copy()]
    drawn.append(noise.exponential(shape).copy())  # the same buffer again: fresh values
    for want, got in zip(expected, drawn, strict=True):
        np.testing.assert_array_equal(got, want)
    assert not np.array_equal(drawn[0], drawn[3])


@pytest.mark.parametrize("value_head", [False, True])
@pytest.mark.parametrize(
    "action_space",
    [
        spaces.Discrete(5),
        spaces.Box(-1, 1, (1,)),
        spaces.Box(-2, 2, (3,)),
        spaces.MultiDiscrete([3, 2]),
        spaces.MultiBinary(3),
    ],
    ids=["discrete", "box1", "box3", "multidiscrete", "multibinary"],
)
def test_evaluate_actions_matches_sb3_distributions(action_space: spaces.Space, value_head: bool) -> None:
    """
    The loss's ``log pi(a|s)`` and entropy (closed forms for categorical and Gaussian policies, SB3's
    distributions otherwise) equal those of SB3's distribution objects, and so do their gradients.
    """
    policy = make_policy(action_space)
    if value_head:
        th.manual_seed(0)
        policy = ReinforcePolicy(OBS_SPACE, action_space, lambda _: 1e-3, value_head=True)
    th.manual_seed(1)
    obs = th.as_tensor(np.stack([OBS_SPACE.sample() for _ in range(64)]))
    action_space.seed(2)
    actions = th.as_tensor(np.stack([action_space.sample() for _ in range(64)])).float()
    if isinstance(action_space, spaces.Discrete):
        actions = actions.long().flatten()

    values, log_prob, entropy = policy.evaluate_actions(obs, actions)
    assert entropy is not None
    distribution = policy.get_distribution(obs)  # SB3's path
    expected_log_prob, expected_entropy = distribution.log_prob(actions), distribution.entropy()
    assert expected_entropy is not None
    th.testing.assert_close(log_prob, expected_log_prob)
    th.testing.assert_close(entropy, expected_entropy)
    expected_values = policy.predict_values(obs)
    th.testing.assert_close(values, expected_values)

    def grads(loss: th.Tensor) -> list[th.Tensor]:
        policy.zero_grad()
        loss.backward()
        return [p.grad.clone() if p.grad is not None else th.zeros_like(p) for p in policy.parameters()]

    ours = grads((log_prob * th.linspace(-1, 1, 64)).mean() + 0.3 * entropy.mean())
    values, log_prob, entropy = policy.evaluate_actions(obs, actions)  # a fresh graph
    distribution = policy.get_distribution(obs)
    sb3 = grads((distribution.log_prob(actions) * th.linspace(-1, 1, 64)).mean() + 0.3 * distribution.entropy().mean())  # type: ignore[union-attr]
    for a, b in zip(ours, sb3, strict=True):
        th.testing.assert_close(a, b)


def test_evaluate_actions_closed_form_is_finite_for_extreme_logits() -> None:
    # An impossible action (logit -inf) adds 0 to the entropy, as in torch's Categorical, not 0 * -inf = NaN
    policy = make_policy(spaces.Discrete(3))
    with th.no_grad():
        policy.action_net.bias.copy_(th.tensor([0.0, -float("inf"), 0.0]))
    obs = th.zeros((2, 4))
    _, log_prob, entropy = policy.evaluate_actions(obs, th.tensor([0, 2]))
    assert entropy is not None and th.isfinite(entropy).all() and th.isfinite(log_prob).all()
    th.testing.assert_close(entropy, policy.get_distribution(obs).entropy())


def test_adam_defaults_to_foreach_and_keeps_the_users_choice() -> None:
    box = spaces.Box(-1, 1, (2,))
    default = ReinforcePolicy(OBS_SPACE, box, lambda _: 1e-3)
    assert default.optimizer_kwargs == {"foreach": True, "eps": 1e-5}  # SB3's eps for Adam, plus foreach
    assert default.optimizer.defaults["foreach"] is True
    assert default.optimizer.defaults["eps"] == 1e-5
    mine = ReinforcePolicy(OBS_SPACE, box, lambda _: 1e-3, optimizer_kwargs=dict(foreach=False, betas=(0.8, 0.9)))
    assert mine.optimizer.defaults["foreach"] is False and mine.optimizer.defaults["betas"] == (0.8, 0.9)
    sgd = ReinforcePolicy(OBS_SPACE, box, lambda _: 1e-3, optimizer_class=th.optim.SGD)
    assert "foreach" not in sgd.optimizer_kwargs


@pytest.mark.parametrize(
    "policy, env_id, policy_kwargs",
    [
        ("CnnPolicy", "image", {}),
        ("MlpPolicy", "CartPole-v1", dict(activation_fn=th.nn.ELU)),  # no NumPy actor: the torch path
        ("MultiInputPolicy", "dict", {}),
    ],
)
def test_unshared_features_extractor(policy: str, env_id: str, policy_kwargs: dict) -> None:
    """
    As SB3's test_cnn.py with ``share_features_extractor=False``: the sampler's torch path reads the actor's own
    features extractor (``extract_features`` would return the actor's and the critic's features as a pair).
    """
    from stable_baselines3.common.envs import FakeImageEnv, SimpleMultiObsEnv

    env = {
        "image": lambda: FakeImageEnv(screen_height=40, screen_width=40, n_channels=1, discrete=True),
        "dict": lambda: SimpleMultiObsEnv(random_start=True),
    }.get(env_id, lambda: gym.make(env_id))()
    kwargs = dict(share_features_extractor=False, **policy_kwargs)
    model = REINFORCE(policy, env, baseline="value", seed=0, policy_kwargs=kwargs)
    assert model.policy.pi_features_extractor is not model.policy.vf_features_extractor
    sampler = model.policy.fast_sampler()
    assert sampler is not None and sampler.numpy_layers is None
    obs = model.get_env().reset()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not SB3's "Provided features_extractor will be ignored"
        params = sampler.distribution_parameters(obs)
    with th.no_grad():
        probs = model.policy.get_distribution(model.policy.obs_to_tensor(obs)[0]).distribution.probs.numpy()
    np.testing.assert_allclose(scipy.special.softmax(params, axis=1), probs, rtol=1e-5, atol=1e-7)
    model.learn(64)
    assert model.num_timesteps >= 64
