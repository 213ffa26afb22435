"""Offline multi-objective recommendation on KuaiRand-format logs (paper Section 6.1).

`kuairand` knows KuaiRand's three layouts (27K, 1K, Pure: their file names) and checks
each value read against KuaiRand's types and ranges, `synth` writes a synthetic data set
in KuaiRand-27K's file format with a known response model, `data` reads a KuaiRand
directory (real or synthetic) and builds the benchmark's offline transitions, `offline`
holds the offline actor-critics (the paper's method and the baselines) and
Behavior-Clone, `alg1` the paper's Algorithm 1 on the logs, `ncis` the off-policy
evaluation, `stats` the bootstrap intervals, `table2` the Table 2 pipeline (train every
method on a data set, score it, summarise over data sets), and `cli` what the command
lines share. Nothing else in `wcac_jax` imports this package.
"""
