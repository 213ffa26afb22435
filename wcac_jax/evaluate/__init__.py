"""A finished run's policies looked at outside training: `python -m wcac_jax.evaluate RUN
--in mo-gymnasium` re-runs them in MO-Gymnasium's v5 environments (`reference`, the
command in `cli`), their actions computed in numpy from the checkpoint (`numpy_policy`);
`render` rolls them out and draws them with MuJoCo's renderer. MO-Gymnasium is optional:
nothing here imports it until an evaluation runs.
"""
