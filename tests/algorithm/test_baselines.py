"""
The baselines keep REINFORCE's gradient unbiased, and reduce its variance: checked against the exact gradient of
a small MDP, computed by dynamic programming. Also the value baseline's own fitting steps (``n_value_steps``).
"""

from pathlib import Path

import numpy as np
import pytest
import torch as th
from hypothesis import given, settings
from hypothesis import strategies as st
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.envs import FakeImageEnv, IdentityEnv
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.reinforce.policies import CnnPolicy
from sb3_reinforce.reinforce.returns import discounted_returns, leave_one_out_baseline

# --- the leave-one-out baseline, against a slow reference -------------------------------------------------


def reference_loo(returns: list[float], lengths: list[int]) -> list[float]:
    """b(i, t): the mean G_t of the other episodes that lasted past t, written the obvious way."""
    episodes, start = [], 0
    for length in lengths:
        episodes.append(returns[start : start + length])
        start += length
    baseline = []
    for i, episode in enumerate(episodes):
        for t in range(len(episode)):
            others = [other[t] for j, other in enumerate(episodes) if j != i and len(other) > t]
            baseline.append(sum(others) / len(others) if others else 0.0)
    return baseline


@settings(max_examples=200, deadline=None)
@given(
    lengths=st.lists(st.integers(min_value=1, max_value=12), min_size=1, max_size=6),
    data=st.data(),
)
def test_leave_one_out_baseline_matches_reference(lengths: list[int], data: st.DataObject) -> None:
    returns = data.draw(
        st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=sum(lengths), max_size=sum(lengths)), label="returns"
    )
    got = leave_one_out_baseline(np.array(returns), np.array(lengths))
    np.testing.assert_allclose(got, reference_loo(returns, lengths), rtol=1e-9, atol=1e-9)


def test_leave_one_out_baseline_checks_lengths() -> None:
    with pytest.raises(ValueError, match="episode_lengths"):
        leave_one_out_baseline(np.zeros(5), np.array([2, 2]))


# --- unbiasedness and variance on a small MDP with an exact gradient ----------------------------------------

N_STATES, N_ACTIONS, HORIZON = 3, 2, 4


def small_mdp(seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return dict(
        start=np.array([0.6, 0.3, 0.1]),
        transitions=rng.dirichlet(np.ones(N_STATES), size=(N_STATES, N_ACTIONS)),  # P(s' | s, a)
        rewards=rng.normal(size=(N_STATES, N_ACTIONS)) + 1.0,
        terminate=rng.uniform(0.1, 0.5, size=(N_STATES, N_ACTIONS)),  # episodes of 1 to HORIZON steps
        logits=rng.normal(size=(N_STATES, N_ACTIONS)),
    )


def exact_gradient(mdp: dict[str, np.ndarray]) -> np.ndarray:
    """grad_theta J for the tabular softmax policy, J = E[sum_t r_t] (gamma = 1, at most HORIZON steps)."""
    logits = th.tensor(mdp["logits"], requires_grad=True)
    pi = th.softmax(logits, dim=1)
    p, r, term = (th.tensor(mdp[k]) for k in ("transitions", "rewards", "terminate"))
    value = th.zeros(N_STATES, dtype=th.float64)  # V_HORIZON = 0
    for _ in range(HORIZON):  # V_t(s) = sum_a pi(a|s) [r(s,a) + (1 - term(s,a)) sum_s' P(s'|s,a) V_{t+1}(s')]
        value = (pi * (r + (1 - term) * (p @ value))).sum(dim=1)
    (th.tensor(mdp["start"]) @ value).backward()
    assert logits.grad is not None
    return logits.grad.numpy().ravel()


def sample_batch(mdp: dict[str, np.ndarray], n_episodes: int, rng: np.random.Generator) -> list[tuple]:
    pi = np.exp(mdp["logits"]) / np.exp(mdp["logits"]).sum(axis=1, keepdims=True)
    episodes = []
    for _ in range(n_episodes):
        states, actions, rewards = [], [], []
        s = rng.choice(N_STATES, p=mdp["start"])
        for _ in range(HORIZON):
            a = rng.choice(N_ACTIONS, p=pi[s])
            states.append(s), actions.append(a), rewards.append(mdp["rewards"][s, a])
            if rng.random() < mdp["terminate"][s, a]:
                break
            s = rng.choice(N_STATES, p=mdp["transitions"][s, a])
        episodes.append((np.array(states), np.array(actions), np.array(rewards)))
    return episodes


def gradient_estimate(mdp: dict[str, np.ndarray], episodes: list[tuple], loo: bool) -> np.ndarray:
    """(1 / K) sum_i sum_t grad log pi(a_t|s_t) (G_t - b_t), with b the leave-one-out mean or 0."""
    pi = np.exp(mdp["logits"]) / np.exp(mdp["logits"]).sum(axis=1, keepdims=True)
    states, actions, rewards = (np.concatenate(part) for part in zip(*episodes, strict=True))
    lengths = np.array([len(e[0]) for e in episodes])
    ends = np.zeros(len(rewards), dtype=bool)
    ends[np.cumsum(lengths) - 1] = True
    returns = discounted_returns(rewards, 1.0, ends)
    weights = returns - leave_one_out_baseline(returns, lengths) if loo else returns
    grad_log_pi = -pi[states]  # d log softmax(l)_a / d l_b = 1[a = b] - pi_b, in the row of state s
    grad_log_pi[np.arange(len(actions)), actions] += 1
    grad = np.zeros((N_STATES, N_ACTIONS))
    np.add.at(grad, states, grad_log_pi * weights[:, None])
    return grad.ravel() / len(episodes)


def test_leave_one_out_baseline_is_unbiased_and_reduces_variance() -> None:
    mdp = small_mdp()
    exact = exact_gradient(mdp)
    rng = np.random.default_rng(1)
    n_batches, n_episodes = 4000, 4
    estimates = {False: [], True: []}
    for _ in range(n_batches):
        episodes = sample_batch(mdp, n_episodes, rng)
        for loo in (False, True):  # the same episodes for both estimators
            estimates[loo].append(gradient_estimate(mdp, episodes, loo))
    for loo, values in estimates.items():
        values = np.array(values)
        standard_error = values.std(axis=0, ddof=1) / np.sqrt(n_batches)
        z = (values.mean(axis=0) - exact) / standard_error
        assert np.all(np.abs(z) < 4.5), f"loo={loo}: the mean estimate is {z.round(2)} standard errors from the exact gradient"
    total_variance = {loo: np.array(values).var(axis=0).sum() for loo, values in estimates.items()}
    assert total_variance[True] < 0.8 * total_variance[False], total_variance


def test_the_check_can_fail() -> None:
    # The same check rejects a biased estimator: a baseline that uses the episode's own return.
    mdp = small_mdp()
    exact = exact_gradient(mdp)
    rng = np.random.default_rng(1)
    values = []
    for _ in range(4000):
        episodes = sample_batch(mdp, 4, rng)
        # b(i, t) = G^i_t / 2: depends on the episode's own actions, so the estimate shrinks by half
        values.append(gradient_estimate(mdp, episodes, loo=False) / 2)
    values = np.array(values)
    z = (values.mean(axis=0) - exact) / (values.std(axis=0, ddof=1) / np.sqrt(len(values)))
    assert np.any(np.abs(z) > 4.5)


# --- REINFORCE's arguments -------------------------------------------------------------------------------------


def test_loo_needs_two_episodes_per_batch() -> None:
    with pytest.raises(ValueError, match=r"baseline='loo'.*n_episodes >= 2 or n_envs >= 2"):
        REINFORCE("MlpPolicy", "CartPole-v1", baseline="loo")
    REINFORCE("MlpPolicy", "CartPole-v1", baseline="loo", n_episodes=2).learn(100)


def test_loo_model_acts_on_one_env_but_does_not_learn_there(tmp_path: Path) -> None:
    # A model trained with 2 envs loads with 1 (predict, evaluate_policy, the zoo's enjoy and record-video), but
    # learning there would give one-episode batches: refused before any step, as the constructor refuses them, until
    # the batch holds two episodes again
    model = REINFORCE("MlpPolicy", make_vec_env("CartPole-v1", n_envs=2, seed=0), baseline="loo", seed=0)
    model.learn(200)
    model.save(tmp_path / "loo")
    single = make_vec_env("CartPole-v1", n_envs=1, seed=1)
    loaded = REINFORCE.load(tmp_path / "loo", env=single)
    mean_return, _ = evaluate_policy(loaded, single, n_eval_episodes=2)
    assert mean_return > 0
    steps = loaded.num_timesteps
    with pytest.raises(ValueError, match=r"baseline='loo'.*n_episodes \* n_envs = 1 \* 1 = 1 episode"):
        loaded.learn(100, reset_num_timesteps=False)
    assert loaded.num_timesteps == steps
    loaded.n_episodes = 2  # two episodes of the one env per batch: it learns
    loaded.learn(100, reset_num_timesteps=False)
    assert loaded.num_timesteps > steps


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n_value_steps=5), "n_value_steps.*baseline='value'"),
        (dict(n_value_steps=5, baseline="loo", n_episodes=2), "n_value_steps.*baseline='value'"),
        (dict(n_value_steps=-1, baseline="value"), "n_value_steps"),
        (dict(n_value_steps=2.0, baseline="value"), "n_value_steps"),
        (dict(value_learning_rate=-1.0, baseline="value", n_value_steps=2), "value_learning_rate"),
        (dict(value_learning_rate="1e-3", baseline="value", n_value_steps=2), "value_learning_rate"),
    ],
)
def test_bad_value_fitting_arguments(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        REINFORCE("MlpPolicy", "NoSuchEnv-v0", **kwargs)


def _one_update(**kwargs) -> REINFORCE:
    model = REINFORCE("MlpPolicy", DummyVecEnv([lambda: IdentityEnv(4)]), n_episodes=2, seed=3, baseline="value", **kwargs)
    model.learn(1)  # one batch, one update
    assert model._n_updates == 1
    return model


def test_value_steps_leave_the_policy_step_unchanged() -> None:
    # The policy's one step does not depend on how the value baseline is fitted afterwards (separate networks):
    # the same advantages (V before fitting) and the same policy loss.
    joint, separate = _one_update(), _one_update(n_value_steps=10, value_learning_rate=1e-2)
    joint_params, separate_params = joint.policy.state_dict(), separate.policy.state_dict()
    policy_keys = [k for k in joint_params if k.startswith(("mlp_extractor.policy_net", "action_net"))]
    value_keys = [k for k in joint_params if k.startswith(("mlp_extractor.value_net", "value_net"))]
    assert policy_keys and value_keys
    for key in policy_keys:
        th.testing.assert_close(joint_params[key], separate_params[key])
    assert all(not th.allclose(joint_params[k], separate_params[k]) for k in value_keys)
    assert separate.value_optimizer is not None and joint.value_optimizer is None
    # ten steps of their own at 1e-2, from the same start: Adam moved each value weight by up to 10 * 1e-2
    moved = max((separate_params[k] - joint_params[k]).abs().max().item() for k in value_keys)
    assert 1e-2 < moved <= 0.1 + 1e-6


def test_value_steps_fit_the_returns() -> None:
    before = _one_update()  # the joint step: one small step of the value head
    model = _one_update(n_value_steps=200, value_learning_rate=1e-2)
    buffer = model.rollout_buffer
    observations = buffer.to_torch(buffer._batch["observations"])
    with th.no_grad():
        errors = [
            np.mean((m.policy.predict_values(observations).flatten().numpy() - buffer.returns) ** 2) for m in (before, model)
        ]
    # IdentityEnv's return-to-go depends on the (unobserved) time step, so V can at best reach about its variance;
    # 200 steps get there from an initial V ~ 0 (an error of about mean(G^2))
    assert errors[1] < 0.3 * errors[0]
    assert errors[1] < 1.2 * np.var(buffer.returns)


class _ValuesThroughTheExtractor(CnnPolicy):
    """A policy that overrides predict_values: each value step then goes through the whole features extractor."""

    def predict_values(self, obs: th.Tensor) -> th.Tensor:
        return super().predict_values(obs)


def test_value_steps_on_cached_features_match_the_full_network() -> None:
    # With a shared CNN the value steps compute its features once per batch and step the critic's layers only:
    # the same weights, bit for bit, as stepping through the whole network (forward and backward through the CNN) each time.
    def image_env(seed: int) -> FakeImageEnv:
        env = FakeImageEnv(screen_height=40, screen_width=40, n_channels=1, discrete=True)
        env.observation_space.seed(seed)  # its observations are samples of its space
        return env

    def trained(policy: type) -> REINFORCE:
        env = DummyVecEnv([lambda: image_env(0), lambda: image_env(1)])
        model = REINFORCE(policy, env, baseline="value", n_value_steps=5, value_learning_rate=1e-3, seed=0)
        return model.learn(40)

    fast, full = trained(CnnPolicy), trained(_ValuesThroughTheExtractor)
    assert fast._n_updates == full._n_updates >= 2
    fast_params, full_params = fast.policy.state_dict(), full.policy.state_dict()
    assert fast_params.keys() == full_params.keys()
    for key in fast_params:
        assert th.equal(fast_params[key], full_params[key]), key  # bit for bit
    # the CNN ran once for the 5 value steps of a batch, against 5 times through predict_values
    observations, returns = th.rand((8, 1, 40, 40)) * 255, th.rand(8)
    for model, expected_calls in ((fast, 1), (full, 5)):
        calls: list[int] = []
        hook = model.policy.features_extractor.register_forward_hook(lambda *args, calls=calls: calls.append(1))
        model._fit_value(observations, returns)
        hook.remove()
        assert len(calls) == expected_calls


def test_value_learning_rate_schedule() -> None:
    # seeded: unseeded, the episodes' lengths sometimes summed to exactly 2,000 and the last batch ended on the budget
    model = REINFORCE(
        "MlpPolicy",
        "CartPole-v1",
        baseline="value",
        n_value_steps=2,
        value_learning_rate=lambda progress: 1e-2 * progress,
        seed=0,
    )
    model.learn(2000)
    assert model.value_optimizer is not None
    lr = model.value_optimizer.param_groups[0]["lr"]
    assert 0 <= lr < 1e-2  # the last batch ends past the budget: progress is floored at 0, never negative
    assert model._current_progress_remaining == 0.0 and model.num_timesteps > 2000
    # by default, the policy's learning rate
    model = REINFORCE("MlpPolicy", "CartPole-v1", baseline="value", n_value_steps=2, learning_rate=3e-4)
    assert model.value_optimizer is not None and model.value_optimizer.param_groups[0]["lr"] == 3e-4


def test_save_load_keeps_the_value_optimizer(tmp_path) -> None:
    model = _one_update(n_value_steps=3, value_learning_rate=2e-3)
    assert model.value_optimizer is not None
    state = model.value_optimizer.state_dict()
    model.save(tmp_path / "model.zip")
    loaded = REINFORCE.load(tmp_path / "model.zip", env=model.get_env())
    assert loaded.n_value_steps == 3 and loaded.value_learning_rate == 2e-3
    assert loaded.value_optimizer is not None
    loaded_state = loaded.value_optimizer.state_dict()["state"]
    assert loaded_state.keys() == state["state"].keys() and loaded_state
    for key, value in state["state"].items():
        th.testing.assert_close(loaded_state[key]["exp_avg"], value["exp_avg"])
    loaded.learn(200, reset_num_timesteps=False)


@pytest.mark.parametrize("kwargs", [dict(baseline="loo", n_episodes=4), dict(baseline="value", n_value_steps=10)])
def test_identity_learned_with_each_baseline(kwargs: dict) -> None:
    env = DummyVecEnv([lambda: IdentityEnv(4)])
    model = REINFORCE("MlpPolicy", env, gamma=0.4, seed=1, **kwargs).learn(3000)
    mean_reward, _ = evaluate_policy(model, env, n_eval_episodes=20, warn=False)
    assert mean_reward >= 90, mean_reward  # of 100: the right action on at least 90% of the steps
