"""
Training on EnvPool (``--vec-env envpool``): SB3's VecEnv contract on the adapter, its wrappers, its errors, the
commands that use it, and the fidelity of every environment offered to Gymnasium's.
"""

import json
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import yaml
from gymnasium.wrappers import GrayscaleObservation, TimeLimit
from rl_zoo3.wrappers import FrameSkip
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import VecEnv, VecFrameStack, VecNormalize

from sb3_reinforce import REINFORCE
from sb3_reinforce.lab.cli import main as cli_main
from sb3_reinforce.lab.compare.command import main as compare_main
from sb3_reinforce.lab.compare.folder import PER_RUN_DIR
from sb3_reinforce.lab.envpool_vec_env import (
    ENVPOOL_ENV_IDS,
    EnvPoolVecEnv,
    WrapperSpec,
    make_envpool_vec_env,
    split_wrappers,
)
from sb3_reinforce.lab.zoo import main as zoo_main
from sb3_reinforce.lab.zoo.exp_manager import wrapper_specs
from sb3_reinforce.lab.zoo.shipped import config_path

#: The CarRacing-v3 zoo entry's wrappers, as the config says them
CAR_RACING_WRAPPERS = wrapper_specs(yaml.safe_load(config_path("reinforce").read_text())["CarRacing-v3"]["env_wrapper"])


def _step_all(env: VecEnv, action: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
    return env.step(np.array([action] * env.num_envs))  # type: ignore[return-value]


# ---------------------------------------------------------------- SB3's VecEnv contract


def test_step_reset_and_terminal_observation() -> None:
    env = make_envpool_vec_env("CartPole-v1", n_envs=3, seed=0)
    assert env.observation_space == gym.make("CartPole-v1").observation_space  # Gymnasium's own spaces
    assert env.action_space == gym.make("CartPole-v1").action_space
    obs = env.reset()
    assert obs.shape == (3, 4) and obs.dtype == np.float32
    steps, returns = np.zeros(3, dtype=int), np.zeros(3)
    ended = 0
    while ended < 6:
        obs, rewards, dones, infos = _step_all(env, 1)  # always right: the pole falls
        assert rewards.shape == (3,) and dones.dtype == bool and len(infos) == 3
        steps += 1
        returns += rewards
        for i in np.flatnonzero(dones):
            info = infos[i]
            assert info["TimeLimit.truncated"] is False  # it fell: terminated, not cut by the time limit
            assert env.observation_space.contains(info["terminal_observation"])
            assert abs(info["terminal_observation"][2]) > 0.2  # the fallen pole
            assert np.all(np.abs(obs[i]) <= 0.05)  # the next episode's first observation (CartPole's reset range)
            assert info["episode"]["l"] == steps[i] and info["episode"]["r"] == pytest.approx(returns[i])
            steps[i], returns[i] = 0, 0.0
            ended += 1
        for i in np.flatnonzero(~dones):
            assert "terminal_observation" not in infos[i] and "episode" not in infos[i]
    env.close()


def test_time_limit_is_truncation() -> None:
    env = make_envpool_vec_env("Pendulum-v1", n_envs=2, seed=0)
    env.reset()
    for _ in range(199):
        _, _, dones, _ = _step_all(env, [0.0])
        assert not dones.any()
    _, _, dones, infos = _step_all(env, [0.0])
    assert dones.all()
    assert all(info["TimeLimit.truncated"] is True and info["episode"]["l"] == 200 for info in infos)
    # The time limit is an argument of both Gymnasium's and EnvPool's environment
    short = make_envpool_vec_env("CartPole-v1", n_envs=2, seed=0, env_kwargs={"max_episode_steps": 3})
    short.reset()
    for expected in (False, False, True):
        _, _, dones, infos = _step_all(short, 0)
        assert list(dones) == [expected, expected]
    assert all(info["TimeLimit.truncated"] is True and info["episode"]["l"] == 3 for info in infos)


def _trajectory(env: VecEnv, steps: int = 60) -> np.ndarray:
    observations = [env.reset()]
    for step in range(steps):
        observations.append(env.step(np.full(env.num_envs, (step // 3) % 2))[0])
    return np.stack(observations)


def test_seeding() -> None:
    env = make_envpool_vec_env("CartPole-v1", n_envs=2, seed=3)
    first = _trajectory(env)
    assert not np.allclose(first[0, 0], first[0, 1])  # each environment has its own seed (3 and 4)
    assert env.seed(3) == [3, 4]
    np.testing.assert_array_equal(_trajectory(env), first)  # seed() applies at the next reset, as SB3's
    env.seed(5)
    seeded = _trajectory(env)
    assert not np.allclose(seeded, first)
    assert not np.allclose(_trajectory(env)[0], seeded[0])  # no seed() since: the environments are not seeded again
    # The other environment of seed 4 is the first of seed 4
    np.testing.assert_array_equal(_trajectory(make_envpool_vec_env("CartPole-v1", n_envs=1, seed=4))[:, 0], first[:, 1])


def test_frame_skip_repeats_actions_until_the_episode_ends() -> None:
    env = make_envpool_vec_env("CartPole-v1", n_envs=2, seed=0, wrappers=[(FrameSkip, {"skip": 3})])
    assert env.frame_skip == 3
    env.reset()
    ends = 0
    while ends < 4:
        _, rewards, dones, infos = _step_all(env, 1)
        assert np.all(rewards[~dones] == 3.0)  # CartPole gives 1 per step of its own
        for i in np.flatnonzero(dones):
            assert 1.0 <= rewards[i] <= 3.0
            assert infos[i]["episode"]["l"] == infos[i]["episode"]["r"]  # lengths count the environment's steps
            ends += 1


def test_car_racing_zoo_wrappers() -> None:
    frame_skip, observation_wrappers = split_wrappers(CAR_RACING_WRAPPERS)
    assert frame_skip == 2 and len(observation_wrappers) == 2
    env = make_envpool_vec_env("CarRacing-v3", n_envs=2, seed=0, wrappers=CAR_RACING_WRAPPERS)
    reference: gym.Env = gym.make("CarRacing-v3")
    for wrapper_class, kwargs in observation_wrappers:
        reference = wrapper_class(reference, **kwargs)
    assert env.observation_space == reference.observation_space == gym.spaces.Box(0, 255, (64, 64, 1), np.uint8)
    assert env.env_is_wrapped(GrayscaleObservation) == [True, True]
    obs = env.reset()
    for _ in range(3):
        assert obs.shape == (2, 64, 64, 1) and obs.dtype == np.uint8 and env.observation_space.contains(obs[0])
        obs = _step_all(env, [0.0, 0.5, 0.0])[0]
    env.close()


def test_under_vec_normalize_and_vec_frame_stack() -> None:
    env = VecFrameStack(VecNormalize(make_envpool_vec_env("CartPole-v1", n_envs=2, seed=0)), n_stack=3)
    obs = env.reset()
    assert obs.shape == (2, 12)
    ended = False
    while not ended:
        obs, _, dones, infos = _step_all(env, 0)
        for i in np.flatnonzero(dones):
            ended = True
            assert infos[i]["terminal_observation"].shape == (12,)  # stacked by VecFrameStack
            np.testing.assert_array_equal(obs[i, :8], 0.0)  # a new episode: the stack starts empty
    env.close()


@pytest.mark.parametrize("env_id", ["CartPole-v1", "LunarLanderContinuous-v3"])
def test_building_and_stepping_warn_nothing(env_id: str) -> None:
    # EnvPool's spaces, built from float64 bounds, made Gymnasium warn four times into compare's progress bar
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # Gymnasium's warnings (not SWIG's DeprecationWarnings at import)
        env = make_envpool_vec_env(env_id, n_envs=2, seed=0)
        env.reset()
        env.step(np.stack([env.action_space.sample() for _ in range(2)]))
        env.close()


def test_attributes_and_methods() -> None:
    env = make_envpool_vec_env("CartPole-v1", n_envs=2, seed=0)
    env.reset()
    assert env.get_attr("render_mode") == [None, None]
    assert env.get_attr("config", indices=[1])[0]["num_envs"] == 2  # the pool's own attributes
    assert not env.has_attr("no_such_attribute")
    with pytest.raises(AttributeError, match="no attribute 'no_such_attribute'"):
        env.get_attr("no_such_attribute")
    with pytest.raises(NotImplementedError, match=r"env_method\('render'\).*dummy or subproc"):
        env.env_method("render")
    with pytest.raises(NotImplementedError, match=r"set_attr\('gravity'\)"):
        env.set_attr("gravity", 1.0)
    assert env.env_is_wrapped(TimeLimit) == [False, False]


def test_bad_input() -> None:
    with pytest.raises(
        ValueError, match=r"BipedalWalker-v3 is not offered on EnvPool: choose among CartPole-v1, .*CarRacing-v3"
    ):
        make_envpool_vec_env("BipedalWalker-v3")
    with pytest.raises(ValueError, match="n_envs must be at least 1"):
        make_envpool_vec_env("CartPole-v1", n_envs=0)
    with pytest.raises(ValueError, match=r"gymnasium.wrappers.common.TimeLimit has no EnvPool equivalent"):
        make_envpool_vec_env("CartPole-v1", wrappers=[(TimeLimit, {"max_episode_steps": 10})])
    with pytest.raises(ValueError, match="env_kwargs gravity of LunarLander-v3 are not arguments of its EnvPool environment"):
        make_envpool_vec_env("LunarLander-v3", env_kwargs={"gravity": -8.0})


def test_without_envpool(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "envpool", None)  # `import envpool` fails as when it is not installed
    with pytest.raises(ModuleNotFoundError, match=r'pip install "sb3-reinforce\[envpool\]"'):
        make_envpool_vec_env("CartPole-v1")
    with pytest.raises(SystemExit) as exit_:
        cli_main(["compare", "--env", "CartPole-v1", "--vec-env", "envpool", "--out", str(tmp_path / "cmp")])
    assert exit_.value.code == 2
    zoo_args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "--vec-env", "envpool", "-f", str(tmp_path)]
    assert zoo_main(zoo_args) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line]
    assert lines == [
        f"{command}: error: the 'envpool' extra is not installed (no module 'envpool'): pip install 'sb3-reinforce[envpool]'"
        for command in ("sb3-reinforce compare", "sb3-reinforce-zoo train")
    ]


# ---------------------------------------------------------------- training on it, through Python and the commands


def test_reinforce_learns_on_envpool_and_is_evaluated_on_gymnasium() -> None:
    model = REINFORCE("MlpPolicy", make_envpool_vec_env("CartPole-v1", n_envs=4, seed=0), seed=0)
    model.learn(2000)
    assert len(model.ep_info_buffer) > 0  # episode statistics from the adapter's monitor
    mean, _ = evaluate_policy(model, gym.make("CartPole-v1"), n_eval_episodes=2)
    assert mean > 0


def test_compare_on_envpool(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cmp"
    args = ["--env", "CartPole-v1", "--algos", "reinforce", "--seeds", "1", "--budget", "1000", "--eval-freq", "500"]
    compare_main([*args, "--eval-episodes", "2", "--vec-env", "envpool", "--workers", "1", "--no-progress", "--out", str(out)])
    summary = json.loads((out / PER_RUN_DIR / "reinforce_seed0.json").read_text())
    assert summary["vec_envs"] == ["envpool"]  # the backend that trained it
    with pytest.raises(SystemExit):
        compare_main(["--env", "BipedalWalker-v3", "--vec-env", "envpool", "--out", str(tmp_path / "no")])
    assert "BipedalWalker-v3 is not offered on EnvPool: choose among CartPole-v1" in capsys.readouterr().err
    assert not (tmp_path / "no" / PER_RUN_DIR).exists()  # refused before anything ran


def test_a_compare_run_steps_envpool_on_one_thread(tmp_path: Path) -> None:
    # A run has one core (one torch thread): its EnvPool gets one worker thread, not EnvPool's one per core, and on
    # a cluster it asks for one CPU whatever its n_envs (a subproc run keeps n_envs busy)
    from sb3_reinforce.lab.compare.experiment import build_run, run_cpus

    assert run_cpus(4, "envpool") == run_cpus(4, "dummy") == 1 and run_cpus(4, "subproc") == 4

    for threads in (1, 0):
        kwargs = {} if threads == 1 else {"envpool_threads": 0}
        built = build_run("reinforce", "CartPole-v1", 0, 1000, tmp_path / str(threads), vec_env="envpool", **kwargs)
        built.train_env.reset()
        env = built.train_env
        while not isinstance(env, EnvPoolVecEnv):
            env = env.venv  # type: ignore[attr-defined]
        assert env.num_threads == threads and env._pool.config["num_threads"] == threads
        built.train_env.close()
        built.eval_env.close()


def test_zoo_train_on_envpool(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["train", "--algo", "reinforce", "--env", "CartPole-v1", "-n", "600", "--seed", "1", "--vec-env", "envpool"]
    assert zoo_main([*args, "--eval-freq", "300", "--eval-episodes", "2", "--verbose", "0", "-f", str(tmp_path)]) == 0
    run_dir = tmp_path / "reinforce" / "CartPole-v1_1"
    assert "- - vec_env\n    - envpool\n" in (run_dir / "CartPole-v1" / "args.yml").read_text()
    assert (run_dir / "envpool.monitor.csv").read_text().count("\n") > 2  # header lines and episodes
    assert len(np.load(run_dir / "evaluations.npz")["results"]) == 2  # evaluated on Gymnasium's env
    assert zoo_main(["train", "--algo", "reinforce", "--env", "BipedalWalker-v3", "--vec-env", "envpool"]) == 2
    assert "--vec-env envpool: BipedalWalker-v3 is not offered on EnvPool" in capsys.readouterr().err


# ---------------------------------------------------------------- fidelity to Gymnasium's environments

#: Two backends score the same when every statistic's means differ by at most this many standard errors of their
#: difference (sqrt(se_a^2 + se_b^2)): a two-sided z test at p = 0.00047 per statistic, so about 0.7% of chance
#: failures over the 15 statistics compared below, were the environments the same. The seeds are fixed, so the
#: test is deterministic.
Z_TOLERANCE = 3.5


def _random_policy(obs: np.ndarray, rng: np.random.Generator, env: VecEnv) -> np.ndarray:
    space = env.action_space
    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(space.n, size=env.num_envs)
    assert isinstance(space, gym.spaces.Box)
    return rng.uniform(space.low, space.high, size=(env.num_envs, *space.shape)).astype(np.float32)


def _push_along(index: int) -> Callable[[np.ndarray, np.random.Generator, VecEnv], np.ndarray]:
    """Action 2 when the observation's ``index`` is positive, else 0 (push along a velocity)."""
    return lambda obs, rng, env: np.where(obs[:, index] > 0, 2, 0)


def _gas(obs: np.ndarray, rng: np.random.Generator, env: VecEnv) -> np.ndarray:
    return np.tile(np.array([0.0, 0.3, 0.0], dtype=np.float32), (env.num_envs, 1))  # straight ahead, gas 0.3


#: Per environment offered: the fixed policy, environments, episodes per environment, and the environment's
#: arguments and wrappers. Heuristics where a random policy learns nothing of the dynamics (Acrobot, MountainCar
#: would always reach their time limit); CarRacing: its zoo wrappers and 150-step episodes (Gymnasium's
#: CarRacing steps about 150 times a second here).
FIDELITY_CASES: dict[str, tuple[Callable[..., np.ndarray], int, int, dict[str, Any], list[WrapperSpec]]] = {
    "CartPole-v1": (_random_policy, 4, 50, {}, []),
    "Acrobot-v1": (_push_along(5), 4, 25, {}, []),  # torque along the second joint's velocity: ~90 steps
    "MountainCar-v0": (_push_along(1), 4, 25, {}, []),  # push along the car's velocity: ~130 steps
    "Pendulum-v1": (_random_policy, 4, 25, {}, []),
    "LunarLander-v3": (_random_policy, 4, 25, {}, []),
    "LunarLanderContinuous-v3": (_random_policy, 4, 25, {}, []),
    "CarRacing-v3": (_gas, 4, 3, {"max_episode_steps": 150}, CAR_RACING_WRAPPERS),
}


def episode_statistics(env: VecEnv, policy: Callable[..., np.ndarray], episodes_per_env: int) -> dict[str, np.ndarray]:
    """
    The first ``episodes_per_env`` episodes of each environment (not the first to end, which would favour short
    ones) under ``policy`` (random draws from a generator seeded 1).

    :return: Their returns, lengths (the environment's own steps) and the mean of their last observations
    """
    rng = np.random.default_rng(1)
    obs = env.reset()
    columns: dict[str, list[list[float]]] = {key: [[] for _ in range(env.num_envs)] for key in ("return", "length", "obs")}
    while min(map(len, columns["return"])) < episodes_per_env:
        obs, _, _, infos = env.step(policy(obs, rng, env))
        for i, info in enumerate(infos):
            if "episode" in info and len(columns["return"][i]) < episodes_per_env:
                columns["return"][i].append(info["episode"]["r"])
                columns["length"][i].append(info["episode"]["l"])
                columns["obs"][i].append(float(np.mean(info["terminal_observation"])))
    env.close()
    return {key: np.concatenate(values) for key, values in columns.items()}


def mismatches(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> list[str]:
    """The statistics whose means differ by more than :data:`Z_TOLERANCE` standard errors, described."""
    found = []
    for key in a:
        difference = abs(a[key].mean() - b[key].mean())
        standard_error = np.sqrt(a[key].var(ddof=1) / len(a[key]) + b[key].var(ddof=1) / len(b[key]))
        if difference > Z_TOLERANCE * standard_error + 1e-6 * max(1.0, abs(a[key].mean())):
            found.append(f"{key}: {a[key].mean():.3f} vs {b[key].mean():.3f} (standard error {standard_error:.3f})")
    return found


def _gymnasium(env_id: str, n_envs: int, env_kwargs: dict[str, Any], wrappers: list[WrapperSpec]) -> VecEnv:
    def wrap(env: gym.Env) -> gym.Env:
        for wrapper_class, kwargs in wrappers:
            env = wrapper_class(env, **kwargs)
        return env

    return make_vec_env(env_id, n_envs, seed=0, env_kwargs=env_kwargs, wrapper_class=wrap)


@pytest.mark.parametrize("env_id", ENVPOOL_ENV_IDS)
def test_envpool_scores_as_gymnasium(env_id: str) -> None:
    """
    The same fixed policy on EnvPool's and on Gymnasium's environment: mean return, mean episode length and the
    mean of the last observations agree within :data:`Z_TOLERANCE` standard errors of their difference, over
    200 episodes (CartPole), 100 (Acrobot, MountainCar, Pendulum, both LunarLanders) or 12 (CarRacing, 150 steps
    each) per backend. At these sizes a LunarLander whose gravity is 20% weaker fails
    (test_fidelity_test_finds_a_drifted_env), and so does a MountainCar cut at 100 steps instead of 200.
    """
    policy, n_envs, episodes, env_kwargs, wrappers = FIDELITY_CASES[env_id]
    on_envpool = episode_statistics(make_envpool_vec_env(env_id, n_envs, 0, wrappers, env_kwargs), policy, episodes)
    on_gymnasium = episode_statistics(_gymnasium(env_id, n_envs, env_kwargs, wrappers), policy, episodes)
    assert len(on_envpool["return"]) == len(on_gymnasium["return"]) == n_envs * episodes
    assert mismatches(on_envpool, on_gymnasium) == []


def test_fidelity_test_finds_a_drifted_env() -> None:
    # Gymnasium's LunarLander with gravity -8 instead of -10: the lander falls slower, its episodes last longer
    policy, n_envs, episodes, _, _ = FIDELITY_CASES["LunarLander-v3"]
    on_envpool = episode_statistics(make_envpool_vec_env("LunarLander-v3", n_envs, 0), policy, episodes)
    drifted = episode_statistics(_gymnasium("LunarLander-v3", n_envs, {"gravity": -8.0}, []), policy, episodes)
    assert any(found.startswith("length") for found in mismatches(on_envpool, drifted))
    # A time limit of 100 steps instead of 200 on MountainCar
    policy, n_envs, episodes, _, _ = FIDELITY_CASES["MountainCar-v0"]
    on_envpool = episode_statistics(make_envpool_vec_env("MountainCar-v0", n_envs, 0), policy, episodes)
    drifted = episode_statistics(_gymnasium("MountainCar-v0", n_envs, {"max_episode_steps": 100}, []), policy, episodes)
    assert any(found.startswith("length") for found in mismatches(on_envpool, drifted))
