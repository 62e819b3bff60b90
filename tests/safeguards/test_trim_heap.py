import sys

import pytest
from stable_baselines3.common.envs import IdentityEnv

from sb3_reinforce import REINFORCE
from sb3_reinforce.safeguards import TrimHeap
from sb3_reinforce.safeguards.callbacks import trim_heap

HAS_MALLOC_TRIM = trim_heap()  # glibc: True (a harmless call); elsewhere nothing happens


def test_trim_heap_available_on_linux_glibc() -> None:
    import platform

    if sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc":
        assert HAS_MALLOC_TRIM
    else:
        assert not HAS_MALLOC_TRIM


@pytest.mark.skipif(not HAS_MALLOC_TRIM, reason="no malloc_trim in this C library")
def test_trim_heap_every_interval_steps() -> None:
    # IdentityEnv: 100-step episodes, one per rollout: a rollout starts every 100 steps
    callback = TrimHeap(interval=250)
    model = REINFORCE("MlpPolicy", IdentityEnv(4), seed=0).learn(1000, callback=callback)
    assert callback.n_trims == 3  # at 300, 600 and 900 steps
    # learn(reset_num_timesteps=True) restarts the step counter: trimming goes on from there
    model.learn(700, callback=callback)
    assert callback.n_trims == 5  # at 300 and 600 again (the counter went back to 0; the last rollout starts at 600)


@pytest.mark.skipif(not HAS_MALLOC_TRIM, reason="no malloc_trim in this C library")
def test_trim_heap_changes_no_result() -> None:
    trimmed = REINFORCE("MlpPolicy", IdentityEnv(4), seed=0).learn(1000, callback=TrimHeap(interval=100))
    plain = REINFORCE("MlpPolicy", IdentityEnv(4), seed=0).learn(1000)
    for a, b in zip(trimmed.policy.parameters(), plain.policy.parameters(), strict=True):
        assert (a == b).all()
