"""
The tooling around the algorithm: the comparison with PPO and A2C (``compare``), rl-baselines3-zoo (``zoo``), the
re-run of the blog post's agent (``seed``), EnvPool's environments, statistics. It imports the algorithm
(:mod:`sb3_reinforce.reinforce`); the algorithm never imports it (docs/architecture.md).
"""
