"""A finished run's policies evaluated outside the project's own compiled program:
`python -m wcac_jax.evaluate RUN --in mo-gymnasium` re-runs them in MO-Gymnasium's v5
environments (`reference`, the command in `cli`), their actions computed in numpy from
the checkpoint (`numpy_policy`). MO-Gymnasium is optional: nothing here imports it until
an evaluation runs.
"""
