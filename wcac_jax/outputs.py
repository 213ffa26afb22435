"""What a sweep writes: the front's summary (`front.json`) and its files.

Every file is written atomically (to a temporary file beside it, then renamed), so an
interrupted run never leaves a half-written result.
"""

from __future__ import annotations

import csv
import importlib.metadata
import io
import json
import os
import platform
import tempfile

import jax
import numpy as np

from wcac_jax import pareto


def write_atomic(path: str, data: bytes) -> None:
    """Writes `data` to a temporary file beside `path`, then renames it over `path`."""
    directory = os.path.dirname(path) or "."
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".tmp-", suffix=os.path.basename(path))
    umask = os.umask(0)
    os.umask(umask)
    os.fchmod(fd, 0o666 & ~umask)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def unwritable_dir(path: str) -> str | None:
    """Why the directory `path` can't be written (or created, with its missing parents,
    and then written), e.g. `"'/x' is not writable"`; `None` if it can. Creates nothing."""
    existing = os.path.abspath(path)
    while not os.path.exists(existing):  # the nearest existing ancestor
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        return f"{existing!r} is not a directory"
    if not os.access(existing, os.W_OK | os.X_OK):
        return f"{existing!r} is not writable"
    return None


# The packages whose numerics a result depends on (MuJoCo's patch releases can change a
# Walker2d front: rounding differences grow over a run).
VERSIONED = ("jax", "jaxlib", "mujoco", "mujoco-mjx", "brax", "flax", "optax", "numpy", "wcac_jax")


def library_versions() -> dict:
    """`{"python": "3.11.7", "jax": "0.10.2", ...}`: what produced a result (`None` for a
    package that is not installed)."""
    versions = {"python": platform.python_version()}
    for name in VERSIONED:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def json_bytes(obj) -> bytes:
    """`obj` as indented JSON (NaN allowed), newline-terminated."""
    return (json.dumps(obj, indent=2, allow_nan=True) + "\n").encode()


def summarize(config, env, prefs, j_ub, hv_ref, metrics, evaluation, timing) -> dict:
    """The `front.json` content of a finished sweep.

    Args:
      config: the sweep's `SweepConfig`.
      env: its environment.
      prefs: `[P, m]` preferences (padding dropped).
      j_ub: `[m]` the fixed utopia point (reported unless the sweep estimated its own).
      hv_ref: `[m]` hypervolume reference point.
      metrics: per-iteration training metrics `[P, T, ...]` on the host.
      evaluation: `eval/return`, `eval/discounted_return` `[P', m]`, `eval/length` `[P']`
        and, for an environment reporting its forward speed, `eval/x_velocity` `[P']`
        (`P' >= P`: rows past `P` are padding).
      timing: `compile_s`, `train_s`, `wall_s`, `steps_this_run`.
    """
    n = prefs.shape[0]
    returns = np.asarray(evaluation["eval/return"])[:n]
    disc = np.asarray(evaluation["eval/discounted_return"])[:n]
    length = np.asarray(evaluation["eval/length"])[:n]
    nd = pareto.nondominated(returns)
    outside = pareto.outside_reference(returns, hv_ref)
    steps = int(metrics["train/env_steps"][0, -1])
    rows = []
    for i in range(n):
        rows.append(
            {
                "pref": prefs[i].tolist(),
                "return": returns[i].tolist(),
                "discounted_return": disc[i].tolist(),
                "episode_length": float(length[i]),
                "lambda": metrics["train/weights"][i, -1].tolist(),
                "g_mu": float(metrics["train/g_mu"][i, -1]),
                "scalarized": float(metrics["train/scalarized"][i, -1]),
                "j_hat": metrics["train/j_hat"][i, -1].tolist(),
                "train_episode_return": metrics["train/episode_return"][i, -1].tolist(),
                "nondominated": bool(nd[i]),
                "inside_hv_ref": not bool(outside[i]),
            }
        )
        if "eval/x_velocity" in evaluation:  # an environment reporting its forward speed
            rows[-1]["mean_x_velocity"] = float(np.asarray(evaluation["eval/x_velocity"])[i])
    return {
        "env": config.env,
        "objective_names": list(env.objective_names),
        # the utopia point in use at the end (the sweep's own estimate, if it made one)
        "j_ub": (
            metrics["train/utopia"][0, -1].tolist() if "train/utopia" in metrics else list(j_ub)
        ),
        "prefs": rows,
        "hypervolume": pareto.hypervolume(returns, hv_ref),
        "hypervolume_discounted": pareto.hypervolume(disc, hv_ref),
        "hv_ref": list(hv_ref),
        # preferences whose (undiscounted) returns do not strictly dominate hv_ref: they
        # add nothing to the hypervolume
        "outside_hv_ref": [i for i in range(n) if outside[i]],
        "cardinality": pareto.cardinality(returns),
        "sparsity": pareto.sparsity(returns),
        "expected_utility": pareto.expected_utility(
            returns, pareto.simplex_lattice(len(j_ub), 101)
        ),
        "env_steps_per_pref": steps,
        "env_steps_total": steps * n,
        "compile_s": timing["compile_s"],
        "train_s": timing["train_s"],
        "wall_s": timing["wall_s"],
        # training throughput of this run (all preferences, compilation excluded); the
        # steps of this process only, so a resumed run reports its own part
        "env_steps_per_s": timing["steps_this_run"] / max(timing["train_s"], 1e-9),
        "devices": [str(d) for d in jax.devices()],
        "versions": library_versions(),
        "config": config.to_dict(),
    }


def write_outputs(out, front, metrics, prefs) -> None:
    """Writes `front.json`, `front.csv`, `curves.npz` and `front.png` to `out`, each
    atomically."""
    write_atomic(os.path.join(out, "front.json"), json_bytes(front))
    buf = io.StringIO()
    names = front["objective_names"]
    writer = csv.writer(buf)
    writer.writerow(
        [f"pref_{n}" for n in names]
        + [f"return_{n}" for n in names]
        + [f"discounted_return_{n}" for n in names]
        + [f"lambda_{n}" for n in names]
        + ["g_mu", "nondominated"]
    )
    for row in front["prefs"]:
        writer.writerow(
            row["pref"]
            + row["return"]
            + row["discounted_return"]
            + row["lambda"]
            + [row["g_mu"], int(row["nondominated"])]
        )
    write_atomic(os.path.join(out, "front.csv"), buf.getvalue().encode())
    npz = io.BytesIO()
    np.savez(npz, prefs=prefs, objective_names=np.array(names), **metrics)
    write_atomic(os.path.join(out, "curves.npz"), npz.getvalue())
    from wcac_jax import plot

    fig = plot.plot_front(front)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=120)
    plot.plt.close(fig)
    write_atomic(os.path.join(out, "front.png"), png.getvalue())
