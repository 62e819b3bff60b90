"""
REINFORCE in the place of A2C and PPO: the one place where SB3's tests' arguments are translated.

SB3's test modules are imported with ``stable_baselines3.A2C`` and ``stable_baselines3.PPO`` bound to the
classes made by :func:`make_substitutes`: subclasses of :class:`~sb3_reinforce.REINFORCE` that take A2C's or
PPO's constructor arguments. Each argument REINFORCE does not take is either translated or dropped, by the
two tables below; every other argument (``learning_rate``, ``gamma``, ``ent_coef``, ``vf_coef``,
``max_grad_norm``, ``use_sde``, ``policy_kwargs``, ``seed``, ...) is passed on unchanged, and one REINFORCE does
not know raises its ``TypeError`` as it would for a user. Arguments the test does not give keep REINFORCE's
defaults (not A2C's or PPO's).

Each variant of the suite fixes the ``baseline`` (``None``: plain REINFORCE, no value network; ``"value"``: a
learned ``V(s)``), unless a test gives one.
"""

from typing import Any, ClassVar

from stable_baselines3.common.type_aliases import GymEnv

from sb3_reinforce import REINFORCE

__all__ = ["DROPPED_ARGUMENTS", "TRANSLATED_ARGUMENTS", "ReinforceInPlaceOf", "make_substitutes", "translate_arguments"]

#: A2C/PPO argument -> (REINFORCE's argument, how the value is carried over)
TRANSLATED_ARGUMENTS: dict[str, tuple[str, str]] = {
    "n_steps": (
        "min_steps",
        "n_steps * n_envs: SB3 collects n_steps steps per environment per update; REINFORCE collects whole episodes "
        "until the batch holds at least min_steps steps (all environments together)",
    ),
    "normalize_advantage": (
        "normalize_returns",
        "the same: standardize the policy-gradient weights over the batch",
    ),
}

#: A2C/PPO argument -> why REINFORCE has no counterpart (the argument is dropped)
DROPPED_ARGUMENTS: dict[str, str] = {
    "gae_lambda": "Monte-Carlo returns (lambda = 1): REINFORCE has no GAE",
    "n_epochs": "one gradient step per batch: no epochs over the batch",
    "batch_size": "one gradient step on the whole batch: no minibatches",
    "clip_range": "no clipped surrogate objective (PPO's)",
    "clip_range_vf": "no clipped value loss (PPO's)",
    "target_kl": "no early stopping of epochs (PPO's)",
    "use_rms_prop": "the optimizer is the policy's optimizer_class (Adam by default), as for PPO",
    "rms_prop_eps": "the optimizer is the policy's optimizer_class (Adam by default), as for PPO",
}


#: REINFORCE's ``max_rollout_steps`` in the suite (its default: 1,000,000). SB3's tests train for a few thousand steps
#: at most; with this cap an environment that never ends an episode stops with ``RolloutLimitError`` in about a
#: second instead of a minute and a half.
MAX_ROLLOUT_STEPS = 10_000


#: REINFORCE's ``seed`` where the test gives none: SB3 leaves some of its models unseeded, and with whole-episode
#: rollouts some outcomes depend on where the last episode ends (test_vec_envs.py::test_video_recorder records a
#: third video when it ends at step 130 or later). Seeded, each test passes or fails the same way on every run,
#: which its strict xfail needs.
DEFAULT_SEED = 0


def translate_arguments(kwargs: dict[str, Any]) -> tuple[dict[str, Any], int | None]:
    """
    REINFORCE's arguments for the A2C/PPO arguments ``kwargs``.

    :param kwargs: The keyword arguments the test gave to A2C or PPO (after ``policy`` and ``env``)
    :return: REINFORCE's keyword arguments, and ``n_steps`` (per environment) if given: ``min_steps`` is
        ``n_steps * n_envs``, known once the environment is wrapped
    """
    translated: dict[str, Any] = {}
    for name, value in kwargs.items():
        if name not in DROPPED_ARGUMENTS:
            translated[TRANSLATED_ARGUMENTS[name][0] if name in TRANSLATED_ARGUMENTS else name] = value
    # n_steps counts the steps of one environment, min_steps those of all: set once the environment is known
    n_steps = translated.pop("min_steps") if "n_steps" in kwargs else None
    return translated, n_steps


class ReinforceInPlaceOf(REINFORCE):
    """
    REINFORCE taking the constructor arguments of the algorithm it replaces (see the module docstring).

    ``learn``'s ``tb_log_name`` defaults to the replaced algorithm's name, as SB3's tests name TensorBoard
    folders after it.
    """

    #: Name of the replaced algorithm ("A2C" or "PPO")
    replaces: ClassVar[str]
    #: The baseline of this variant of the suite, used when the test gives none
    variant_baseline: ClassVar[str | None]

    def __init__(self, policy: Any, env: GymEnv | str, **kwargs: Any):
        kwargs, n_steps = translate_arguments(kwargs)
        kwargs.setdefault("baseline", self.variant_baseline)
        kwargs.setdefault("max_rollout_steps", MAX_ROLLOUT_STEPS)
        if kwargs.get("seed") is None:
            kwargs["seed"] = DEFAULT_SEED
        init_setup_model = kwargs.pop("_init_setup_model", True)
        super().__init__(policy, env, _init_setup_model=False, **kwargs)
        if n_steps is not None:
            self.min_steps = n_steps * self.n_envs
        if init_setup_model:
            self._setup_model()

    def learn(self, total_timesteps: int, *args: Any, **kwargs: Any) -> Any:
        if len(args) < 3:  # (callback, log_interval, tb_log_name, ...) positionally: keep the test's
            kwargs.setdefault("tb_log_name", self.replaces)
        return super().learn(total_timesteps, *args, **kwargs)


def make_substitutes(baseline: str | None) -> dict[str, type[ReinforceInPlaceOf]]:
    """
    The classes that take A2C's and PPO's places in one variant of the suite.

    :param baseline: REINFORCE's ``baseline`` in this variant (None or "value")
    :return: ``{"A2C": class, "PPO": class}``
    """
    return {
        name: type(
            f"REINFORCE_as_{name}",  # the name in test ids: the variant's name says the baseline
            (ReinforceInPlaceOf,),
            {"replaces": name, "variant_baseline": baseline, "__module__": __name__},
        )
        for name in ("A2C", "PPO")
    }
