"""The offline Table 2 pipeline, one data set at a time: every method trained with its
training seeds (`train_data_set`), each policy's per-row pieces of its scores on the test
rows (`score_rows`: NCIS weights and, on synthetic data, the true expected signals), the
table's point estimates with 95% bootstrap intervals over data sets, test rows and seeds
(`summarise`), and Fig. 2's leaning preferences against the unified one (`fig2_scores`).

`experiments/kuairand_table2.py` is its command line: it reads the data sets, runs this
pipeline on each and writes the tables and figures.
"""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.recsys import alg1, offline, stats
from wcac_jax.recsys import ncis as ncis_lib
from wcac_jax.recsys.data import SIGNALS, Protocol, for_test_rows
from wcac_jax.recsys.synth import ResponseModel

NAMES = {
    "bc": "Behavior-Clone",
    "moac": "MOAC (linear)",
    "mocha": "MOCHA (linear)",
    "pdpg": "PDPG (DNN)",
    "wcac": "wcac (DDPG-style)",
    "alg1": "wcac (Algorithm 1)",
    "oracle": "Oracle",
}
ACTOR_CRITICS = ("moac", "mocha", "pdpg", "wcac", "alg1")
ORDER = ("bc", *ACTOR_CRITICS, "oracle")
UNIFIED = np.full(7, 1.0 / 7)
LEAN = 0.4  # a leaning preference: 0.4 on its signal, 0.1 on each of the six others
CURVE_POINTS = 40  # training curves: means over this many equal windows of the steps


def leaning_prefs() -> np.ndarray:
    """`[7, 7]`: row `i` puts `LEAN` on signal `i` and the rest evenly on the others."""
    p = np.full((7, 7), (1.0 - LEAN) / 6)
    np.fill_diagonal(p, LEAN)
    return p


def actions_on_rows(act, params, data: Protocol, batch_axis: bool, rows=None, chunk: int = 4096):
    """The policy's `action(s)` on `rows` (default: the test rows, with the test split's
    normalisation, `for_test_rows`; pass that yourself with other test `rows`): `[P, n]`
    (or `[n]`)."""
    fn = jax.jit(jax.vmap(act, in_axes=(0, None)) if batch_axis else act)
    if rows is None:
        data, rows = for_test_rows(data), np.arange(data.n_train, data.n_rows)
    out = []
    for start in range(0, rows.shape[0], chunk):
        r = jnp.asarray(rows[start : start + chunk])
        out.append(np.asarray(fn(params, offline.net_input(data, r))))
    return np.concatenate(out, axis=-1)


def logged_contexts(model: ResponseModel, data: Protocol) -> np.ndarray:
    """`[n_test, K]` each test row's logged session context (video ids, -1 none)."""
    return model.logged_context(np.asarray(data.log_row[data.n_train :]))


def truth_tables(model: ResponseModel, data: Protocol, chunk: int = 1024):
    """`[n_test, C, 7]` true expected signals of each candidate shown in place of each
    test row's logged video: that row's user, in that row's logged session context."""
    users = data.user_ids[np.asarray(data.user_index[data.n_train :])]
    context = logged_contexts(model, data)
    out = np.empty((users.shape[0], data.n_candidates, 7), np.float32)
    for s in range(0, users.shape[0], chunk):  # [chunk, C, K] intermediates stay small
        out[s : s + chunk] = model.expected(
            users[s : s + chunk, None], data.video_ids[None, :], context[s : s + chunk, None, :]
        )
    return jnp.asarray(out)


def percent(diff: float, ref: float):
    """`100 diff / |ref|`, or None (JSON null) when `ref` is 0."""
    return None if ref == 0 else 100.0 * float(diff) / abs(float(ref))


def window_means(metrics: dict) -> dict:
    """Per seed, the critic loss and the mean action averaged over `CURVE_POINTS` equal
    windows of the training steps: `{name: [S, points]}`."""
    out = {}
    for key in ("critic_loss", "mean_action"):
        x = np.asarray(metrics[f"train/{key}"], np.float64)  # [S, steps]
        points = min(CURVE_POINTS, x.shape[1])
        n = x.shape[1] - x.shape[1] % points
        out[key] = x[:, :n].reshape(x.shape[0], points, -1).mean(axis=-1).tolist()
    return out


def train_data_set(data: Protocol, cfg, acfg, key, seeds: int, lean: bool, log):
    """Every method on one data set: `(actions, curves, behaviour, times)`.

    `actions[method]` is `[S, n_test]` (wcac (Algorithm 1) `[S + 7, n_test]` with `lean`:
    the 7 leaning preferences of Fig. 2 after the unified ones); `behaviour` `[n_rows]` is
    the behaviour model's action on every row, a Behavior-Clone of its own key.
    """
    obj = offline.objectives(data, cfg.gamma, cfg.ub_margin)
    keys = jax.random.split(key, len(ORDER) + 1)
    actions, curves, times = {}, {}, {}
    t = time.perf_counter()
    bc_train, bc_act = offline.make_train_bc(cfg, data)
    bc_keys = jax.random.split(keys[0], seeds + 1)  # the last: the behaviour model
    bc_params, bc_losses = jax.jit(jax.vmap(bc_train, in_axes=(0, None)))(bc_keys, data)
    for losses in np.asarray(bc_losses):  # one row per key
        offline.check_finite(NAMES["bc"], "loss", losses)
    train_rows, test_rows = np.arange(data.n_train), np.arange(data.n_train, data.n_rows)
    every = np.concatenate(  # each split's rows with its own normalisation (tscac)
        [
            actions_on_rows(bc_act, bc_params, data, True, rows=train_rows),
            actions_on_rows(bc_act, bc_params, for_test_rows(data), True, rows=test_rows),
        ],
        axis=-1,
    )
    behaviour = every[-1]
    actions["bc"] = every[:seeds, data.n_train :]
    times["bc"] = time.perf_counter() - t
    log(f"  Behavior-Clone x{seeds + 1}: {times['bc']:.1f}s")
    for i, method in enumerate(ACTOR_CRITICS, 1):
        prefs = np.repeat(UNIFIED[None], seeds, axis=0)
        if method == "alg1" and lean:
            prefs = np.vstack([prefs, leaning_prefs()])
        pkeys = jax.random.split(keys[i], seeds)
        pkeys = jnp.concatenate([pkeys, jnp.repeat(pkeys[:1], len(prefs) - seeds, axis=0)])
        t = time.perf_counter()
        prefs = jnp.asarray(prefs, jnp.float32)
        if method == "alg1":
            train, act = alg1.make_train(cfg, acfg, data)
            sweep = jax.jit(jax.vmap(train, in_axes=(0, 0, None, None, None)))
            state, metrics = sweep(pkeys, prefs, data, obj, jnp.asarray(behaviour))
        else:
            train, act = offline.make_train(method, cfg, data)
            sweep = jax.jit(jax.vmap(train, in_axes=(0, 0, None, None)))
            state, metrics = sweep(pkeys, prefs, data, obj)
        jax.block_until_ready(state)
        offline.check_finite(NAMES[method], "critic loss", metrics["train/critic_loss"])
        offline.check_finite(NAMES[method], "mean action", metrics["train/mean_action"])
        actions[method] = actions_on_rows(act, state.actor, data, True)
        curves[method] = window_means(jax.tree.map(lambda x: x[:seeds], metrics))
        times[method] = time.perf_counter() - t
        log(
            f"  {NAMES[method]}: P={prefs.shape[0]}, {times[method]:.1f}s, mean test action "
            f"{actions[method][:seeds].mean():.1f} (logged "
            f"{float(data.action[data.n_train :].mean()):.1f})"
        )
    return actions, curves, behaviour, obj, times


def score_rows(actions, behaviour, data: Protocol, truth_table, coeff):
    """Per method the per-row pieces the table is made of (host numpy):
    `w [S, n]`, `wr [S, n, 7]` (NCIS) and, with a truth table, `true [S, n, 8]` (the seven
    signals and the unified objective `signals . coeff`), and each run's ESS `[S]`."""
    logged = data.action[data.n_train :].astype(jnp.float32)
    reward = np.asarray(data.reward[data.n_train :], np.float64)
    beh = jnp.asarray(behaviour[data.n_train :], jnp.float32)
    out = {}
    for key, acts in actions.items():
        w = np.stack(
            [np.asarray(ncis_lib.importance_weights(jnp.asarray(a), beh, logged)) for a in acts]
        ).astype(np.float64)
        rows = {"w": w, "wr": w[:, :, None] * reward[None]}
        rows["ess"] = np.array([float(ncis_lib.effective_sample_size(x)) for x in w])
        if truth_table is not None:
            true = np.stack(
                [np.asarray(ncis_lib.true_rows(jnp.asarray(a), truth_table)) for a in acts]
            ).astype(np.float64)
            rows["true"] = np.concatenate([true, (true @ coeff)[..., None]], axis=-1)
        out[key] = rows
    return out


def signals(x) -> dict:
    return dict(zip(SIGNALS, np.asarray(x).tolist(), strict=True))


def nulls(x):
    """nan -> None (JSON null), elementwise over nested lists."""
    if isinstance(x, list):
        return [nulls(v) for v in x]
    return None if not np.isfinite(x) else float(x)


def per_seed(scores: dict) -> dict:
    """One data set's estimates per method and training seed on all of its test rows:
    `{method: {"ncis": [S, 7], "truth": [S, 7], "unified_truth": [S]}}` (the truth
    entries only with a response model). The table's point estimates are their means over
    seeds, then data sets."""
    out = {}
    for k in ORDER:
        sc = scores[k]
        row = {"ncis": (sc["wr"].sum(axis=1) / sc["w"].sum(axis=1)[:, None]).tolist()}
        if "true" in sc:
            true = sc["true"].mean(axis=1)  # [S, 8]
            row |= {"truth": true[:, :7].tolist(), "unified_truth": true[:, 7].tolist()}
        out[NAMES[k]] = row
    return out


def summarise(per_data: list, draws: list, has_truth: bool, set_draws=None) -> dict:
    """`table.json`'s `methods`: point estimates, 95% intervals, changes vs Behavior-Clone
    (paired), ESS and, with the truth, the unified objective and the gap share: its
    interval over test rows and seeds (conditional on the data sets), its value on each
    data set, and (with `set_draws`) its interval with the data sets resampled too."""
    ncis_rep = {
        k: stats.ncis_replicates(
            [d[k]["w"] for d in per_data], [d[k]["wr"] for d in per_data], draws
        )
        for k in ORDER
    }
    ones = [
        stats.Draws(np.ones((1, d.counts.shape[1])), np.arange(d.seeds.shape[1])[None])
        for d in draws
    ]
    ncis_pt = {
        k: stats.ncis_replicates(
            [d[k]["w"] for d in per_data], [d[k]["wr"] for d in per_data], ones
        )[0]
        for k in ORDER
    }
    if has_truth:
        true_rep = {
            k: stats.mean_replicates([d[k]["true"] for d in per_data], draws) for k in ORDER
        }
        true_pt = {k: stats.point([d[k]["true"].mean(axis=1) for d in per_data]) for k in ORDER}
    methods = {}
    for k in ORDER:
        rel_rep = stats.relative(ncis_rep[k], ncis_rep["bc"])
        row = {
            "ncis": signals(ncis_pt[k]),
            "ncis_ci95": signals(stats.ci95(ncis_rep[k])),
            "vs_bc": signals(nulls(stats.relative(ncis_pt[k], ncis_pt["bc"]).tolist())),
            "vs_bc_ci95": signals(nulls(stats.ci95(rel_rep).tolist())),
            "ess": float(np.mean([d[k]["ess"].mean() for d in per_data])),
        }
        if has_truth:
            t_rep, t_pt = true_rep[k], true_pt[k]
            rel_rep = stats.relative(t_rep[:, :7], true_rep["bc"][:, :7])
            diff_rep = t_rep[:, 7] - true_rep["bc"][:, 7]
            gap_rep = stats.gap_share(t_rep[:, 7], true_rep["bc"][:, 7], true_rep["oracle"][:, 7])
            row |= {
                "truth": signals(t_pt[:7]),
                "truth_ci95": signals(stats.ci95(t_rep[:, :7])),
                "truth_vs_bc": signals(nulls(stats.relative(t_pt[:7], true_pt["bc"][:7]).tolist())),
                "truth_vs_bc_ci95": signals(nulls(stats.ci95(rel_rep).tolist())),
                "unified_truth": float(t_pt[7]),
                "unified_truth_ci95": stats.ci95(t_rep[:, 7]).tolist(),
                "unified_vs_bc": float(t_pt[7] - true_pt["bc"][7]),
                "unified_vs_bc_ci95": stats.ci95(diff_rep).tolist(),
                "gap_share": float(
                    stats.gap_share(t_pt[7], true_pt["bc"][7], true_pt["oracle"][7])
                ),
                "gap_share_ci95": stats.ci95(gap_rep).tolist(),
                "gap_share_by_data_set": [
                    float(
                        stats.gap_share(*(d[j]["true"][..., 7].mean() for j in (k, "bc", "oracle")))
                    )
                    for d in per_data
                ],
            }
            if set_draws is not None:
                unified = {
                    j: stats.set_replicates(
                        [d[j]["true"][:, :, 7].mean(axis=1)[:, None] for d in per_data], set_draws
                    )[:, 0]
                    for j in (k, "bc", "oracle")
                }
                sets_rep = stats.gap_share(unified[k], unified["bc"], unified["oracle"])
                row["gap_share_ci95_data_sets"] = stats.ci95(sets_rep).tolist()
        methods[NAMES[k]] = row
    return methods


def fig2_scores(leaning, unified, behaviour, data: Protocol, truth_table) -> dict:
    """Fig. 2: the 7 leaning policies against the unified one (NCIS and truth, %)."""
    logged = data.action[data.n_train :].astype(jnp.float32)
    reward = data.reward[data.n_train :]
    beh = jnp.asarray(behaviour[data.n_train :], jnp.float32)
    sign = np.array([-1.0 if s == "hate" else 1.0 for s in SIGNALS])
    out = {"values": {}, "improvement": {}}
    for kind in ("ncis", "truth"):
        if kind == "truth" and truth_table is None:
            continue
        vals = []
        for a in [unified, *leaning]:
            a = jnp.asarray(a, jnp.float32)
            if kind == "ncis":
                vals.append(np.asarray(ncis_lib.ncis(a, beh, logged, reward)))
            else:
                vals.append(np.asarray(ncis_lib.true_value(a, truth_table)))
        vals = np.array(vals)
        ref = vals[0]
        out["values"][kind] = {"unified": ref.tolist(), "leaning": vals[1:].tolist()}
        # a reference of 0 (no event in the test rows) has no relative change: null
        out["improvement"][kind] = [
            [percent(sign[j] * (v[j] - ref[j]), ref[j]) for j in range(7)] for v in vals[1:]
        ]
    return out
