"""Command-line arguments of a tiny concave-bandit sweep (compiles in seconds): the
paper's recipe (`--preset paper`) at tiny sizes."""

TINY_BANDIT = [
    *("--preset", "paper", "--env", "concave_bandit"),
    *("--envs-per-pref", "8", "--critic-steps", "2", "--rollout-steps", "4"),
    *("--network", "mlp", "--width", "16", "--depth", "1"),
    *("--steps-per-pref", "1200", "--eval-episodes", "2"),
]
