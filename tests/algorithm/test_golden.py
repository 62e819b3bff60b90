"""
Golden numbers: a fixed seed gives the same training, to the bit, before and after a refactoring.

Each case trains REINFORCE for a few thousand steps from a fixed seed and compares every finished episode's
return and a checksum of the final weights with the numbers in ``tests/algorithm/golden.json``, produced by the code of
commit 6ba24a4 (before the package was reshaped for issue 46) with ``python -m tests.test_golden >
tests/algorithm/golden.json``. A change that moves one draw of the random generators, one floating-point operation of the
loss or one step of the rollout changes them. Update them only for a change meant to alter training, and say so
in its commit.

Bit for bit holds on one CPU type with one set of library versions: torch picks its CPU kernels by the instruction
set, and another machine rounds the same computation differently in the last bits (the first Pendulum-v1 episode,
played by the untrained policy, already differs in its 7th digit). ``golden_other_systems.json`` holds the same cases
recorded, by the same unchanged training code, on other systems (each with its CPU, torch's CPU capability and the
versions); a result must equal one recording exactly, whichever: the system's name does not decide the numbers
(an AMD EPYC with torch's AVX-512 kernels computes golden.json's, as an AMD EPYC with AVX2 did, while CI's machine
computed, on 2026-12-02, exactly the Intel AVX-512 recording). On a system with none, record one from a commit whose training
is known to be unchanged: ``python -m tests.algorithm.test_golden --system``.
"""

import json
import pathlib
import sys
from typing import Any

import pytest
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.envs import IdentityEnvMultiBinary, IdentityEnvMultiDiscrete

from sb3_reinforce import REINFORCE

#: The constructor's hyperparameter defaults when the numbers were recorded, passed explicitly (below the cases' own
#: arguments), so that new defaults leave the recorded training as it was. Every hyperparameter but ``seed`` and
#: ``stats_window_size`` (set by :func:`train`); ``tensorboard_log`` and ``verbose`` do not touch training.
RECORDED_DEFAULTS: dict[str, Any] = dict(
    learning_rate=1e-3,
    n_episodes=1,
    min_steps=0,
    gamma=0.99,
    baseline=None,
    normalize_returns=True,
    ent_coef=0.0,
    vf_coef=0.5,
    n_value_steps=0,
    value_learning_rate=None,
    max_grad_norm=None,
    use_sde=False,
    sde_sample_freq=-1,
    max_rollout_steps=1_000_000,
    rollout_buffer_class=None,
    rollout_buffer_kwargs=None,
    tensorboard_log=None,
    policy_kwargs=None,
    verbose=0,
)
#: name: (environment, n_envs, REINFORCE's arguments, steps)
CASES: dict[str, tuple[Any, int, dict[str, Any], int]] = {
    "cartpole_plain": ("CartPole-v1", 1, {}, 3_000),
    "cartpole_value_steps_4envs": ("CartPole-v1", 4, dict(baseline="value", n_value_steps=5, n_episodes=2), 4_000),
    "cartpole_loo": ("CartPole-v1", 1, dict(baseline="loo", n_episodes=4, max_grad_norm=0.5), 3_000),
    "pendulum_value_joint": ("Pendulum-v1", 2, dict(baseline="value", min_steps=400, learning_rate=3e-3), 4_000),
    "pendulum_plain_sde": ("Pendulum-v1", 1, dict(use_sde=True, sde_sample_freq=4), 2_000),
    "multidiscrete": (lambda: IdentityEnvMultiDiscrete(dim=3, ep_length=10), 1, dict(n_episodes=2), 1_000),
    "multibinary": (lambda: IdentityEnvMultiBinary(dim=3, ep_length=10), 2, dict(ent_coef=0.01), 1_000),
}


def train(name: str) -> dict[str, Any]:
    """Train one case; return its episodes' returns and the checksum of its weights."""
    env_id, n_envs, kwargs, steps = CASES[name]
    env = make_vec_env(env_id, n_envs=n_envs, seed=0)
    model = REINFORCE("MlpPolicy", env, seed=0, stats_window_size=100_000, **(RECORDED_DEFAULTS | kwargs))
    model.learn(steps)
    returns = [float(info["r"]) for info in model.ep_info_buffer]
    checksum = float(sum(p.detach().double().sum() for p in model.policy.parameters()))
    return {"n_timesteps": model.num_timesteps, "returns": returns, "weights_checksum": checksum}


HERE = pathlib.Path(__file__).parent
#: Recorded at commit 6ba24a4 (see the module docstring): tests/algorithm/golden.json
GOLDEN: dict[str, dict[str, Any]] = json.loads((HERE / "golden.json").read_text())
#: The same cases recorded on other systems: [{"system": ..., "recorded_with": ..., "cases": {name: result}}]
OTHER_SYSTEMS: list[dict[str, Any]] = json.loads((HERE / "golden_other_systems.json").read_text())
#: What a recording's system names (torch's CPU capability: the instruction set of its CPU kernels)
SYSTEM_KEYS = ("CPU", "PyTorch CPU capability", "PyTorch", "Numpy", "Gymnasium", "Stable-Baselines3", "Python")


def this_system() -> dict[str, str]:
    """This machine's CPU, torch's CPU capability and the versions that decide the numbers."""
    from sb3_reinforce.lab.provenance import system_info

    info = system_info()
    return {key: info[key] for key in SYSTEM_KEYS}


@pytest.mark.parametrize("name", sorted(CASES))
def test_same_seed_same_training(name: str) -> None:
    th.set_num_threads(1)
    result = train(name)
    recordings = {"golden.json (6ba24a4)": GOLDEN[name]}
    recordings |= {f"golden_other_systems.json: {other['system']}": other["cases"][name] for other in OTHER_SYSTEMS}
    if any(result == recorded for recorded in recordings.values()):
        return
    # None matched: a readable diff against this system's recording if it has one (the module docstring: any
    # recording is accepted above, since the system's name does not decide the numbers)
    ours = [other["cases"][name] for other in OTHER_SYSTEMS if other["system"] == this_system()]
    expected = ours[0] if ours else GOLDEN[name]
    message = f"{name} equals no recording ({list(recordings)}) on {this_system()}"
    assert result["n_timesteps"] == expected["n_timesteps"], message
    assert result["returns"] == expected["returns"], message
    assert result["weights_checksum"] == expected["weights_checksum"], message
    raise AssertionError(message)


def test_recorded_defaults_name_every_hyperparameter() -> None:
    # A new hyperparameter joins RECORDED_DEFAULTS at the value that leaves the recorded training unchanged
    from sb3_reinforce.reinforce.reinforce import hyperparameter_defaults

    assert set(RECORDED_DEFAULTS) | {"seed", "stats_window_size"} == set(hyperparameter_defaults())


if __name__ == "__main__":
    # python -m tests.algorithm.test_golden > tests/algorithm/golden.json: the numbers; with --system, a recording of
    # this system to add to golden_other_systems.json's list
    th.set_num_threads(1)
    cases = {name: train(name) for name in sorted(CASES)}
    if "--system" in sys.argv:
        recording = {"system": this_system(), "recorded_with": "python -m tests.algorithm.test_golden --system"}
        json.dump(recording | {"cases": cases}, sys.stdout, indent=1)
    else:
        json.dump(cases, sys.stdout, indent=1)
