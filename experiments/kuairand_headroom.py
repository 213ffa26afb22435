"""How much the recommendation table can show: the Behavior-Clone -> oracle gap of the
unified objective against the evaluation's Gaussian width sigma (no actor-critic trained).

    python experiments/kuairand_headroom.py --data DIR [DIR ...] --out OUT [--steps T]
        [--protocol default|tscac]

On each synthetic `DIR` (one per data seed): Behavior-Clone (the table's configuration),
then, for each `sigma`, the true value of the unified objective (`kuairand_table2`'s) of
Behavior-Clone's Gaussian, of the oracle's (the best mean per test row for that sigma),
and of the logged actions, each test row valued in its logged session context. Writes
`OUT/headroom.json`: per sigma, the means over data sets and the gap
`oracle - bc` in units of the unified objective. A non-empty `OUT` is refused unless
`--overwrite` is given; then it is replaced whole once the new results are written.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
from dataclasses import replace

import jax
import jax.numpy as jnp
import kuairand_table2
import numpy as np

from wcac_jax.recsys import ncis as ncis_lib
from wcac_jax.recsys import offline, table2
from wcac_jax.recsys.cli import ArgumentParser
from wcac_jax.recsys.data import PROTOCOLS, load
from wcac_jax.recsys.synth import MODEL_FILE, ResponseModel
from wcac_jax.sweep.outputs import out_refusal, replace_dir, staging_dir

SIGMAS = (25.0, 10.0, 5.0, 2.0, 0.5)


def headroom(data_dir: str, cfg: offline.OfflineConfig, seed: int, protocol="default") -> dict:
    """`{sigma: {"bc", "oracle", "gap"}}` and the logged actions' value on one data set."""
    data = load(data_dir, protocol=protocol)
    model = ResponseModel.load(os.path.join(data_dir, MODEL_FILE))
    obj = offline.objectives(data, cfg.gamma, cfg.ub_margin)
    coeff = table2.UNIFIED * np.asarray(obj.scale, np.float64) / (1.0 - cfg.gamma)
    truth = table2.truth_tables(model, data)  # [n, C, 7]
    train, act = offline.make_train_bc(cfg, data)
    params, _ = jax.jit(train)(jax.random.key(seed), data)
    bc = jnp.asarray(table2.actions_on_rows(act, params, data, False), jnp.float32)
    c32 = jnp.asarray(coeff, jnp.float32)
    out = {}
    for sigma in SIGMAS:
        oracle = ncis_lib.oracle_actions(truth, c32, sigma)
        v_bc = float(np.asarray(ncis_lib.true_value(bc, truth, sigma)) @ coeff)
        v_or = float(np.asarray(ncis_lib.true_value(oracle, truth, sigma)) @ coeff)
        out[str(sigma)] = {"bc": v_bc, "oracle": v_or, "gap": v_or - v_bc}
    logged = np.asarray(data.action[data.n_train :])
    rows = np.arange(logged.shape[0])
    logged_value = float(np.asarray(truth)[rows, logged].mean(axis=0) @ coeff)
    return {"sigma": out, "logged": logged_value}


def main(argv=None) -> int:
    parser = ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, nargs="+")
    parser.add_argument("--out", required=True)
    parser.add_argument("--steps", type=int, default=kuairand_table2.DEFAULT.steps)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--protocol", choices=PROTOCOLS, default="default")
    parser.add_argument("--overwrite", action="store_true", help="replace a non-empty --out whole")
    args = parser.parse_args(argv)
    refusal = out_refusal(args.out, args.overwrite)  # before any work
    if refusal:
        print(f"error: {refusal}", file=sys.stderr)
        return 2
    cfg = replace(kuairand_table2.DEFAULT, steps=args.steps)
    per = [headroom(d, cfg, args.seed, args.protocol) for d in args.data]
    result = {
        "protocol": args.protocol,
        "data_seeds": [os.path.basename(os.path.normpath(d)) for d in args.data],
        "bc_steps": cfg.steps,
        "sigma": {
            s: {k: float(np.mean([p["sigma"][s][k] for p in per])) for k in ("bc", "oracle", "gap")}
            for s in per[0]["sigma"]
        },
        "logged": float(np.mean([p["logged"] for p in per])),
        "per_data_set": per,
    }
    # written beside --out, then renamed over it: an interrupted run leaves --out whole
    work = staging_dir(args.out)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    with open(os.path.join(work, "headroom.json"), "w") as f:
        f.write(json.dumps(result, indent=2) + "\n")
    replace_dir(work, args.out)
    print(json.dumps(result["sigma"], indent=1), "logged", result["logged"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
