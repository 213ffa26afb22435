"""The method's pieces, pure and jittable: the configurations' base (`config`), the pytree
types and key convention (`types`), the networks (`networks`), the scalarizations
(`scalarize`), the utopia point (`utopia`), the paper's critic and actor steps (`critic`,
`actor`), the generic on-policy losses (`losses`), the episode wrapper (`episodes`) and
what every update shares (`runtime`: the `Trainer`, rollouts, evaluation).

Nothing here imports anything of `wcac_jax` outside `core`: the updates (`wcac_jax.algos`)
are built from these pieces, the tasks (`wcac_jax.envs`) use only the episode wrapper and
the scalarizations, and the host side (`wcac_jax.sweep`, `evaluate`, `recsys`) calls them.
Each module loads on its own (this package imports none of them).
"""
