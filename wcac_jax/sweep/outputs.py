"""What a sweep writes: the front's summary (`front.json`) and its files.

Every file is written atomically (to a temporary file beside it, then renamed), and
`front.json`, which marks a sweep finished, last, so an interrupted run never leaves a
half-written result.
"""

from __future__ import annotations

import csv
import importlib.metadata
import io
import json
import os
import platform
import shutil
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


def staging_dir(out: str) -> str:
    """Where a run that replaces the results in `out` writes them first: a hidden
    directory beside `out`, on the same file system, renamed over `out` once every file is
    written (`replace_dir`), so that an interrupted run leaves `out` whole."""
    parent, name = os.path.split(os.path.abspath(out))
    return os.path.join(parent, f".{name}.overwrite")


def fresh_staging_dir(out: str) -> tuple[str, str | None]:
    """`(staging_dir(out), None)` with the staging directory emptied of an earlier,
    interrupted try's and created; or `(its path, why it can't be written)`, creating
    nothing."""
    work = staging_dir(out)
    shutil.rmtree(work, ignore_errors=True)
    problem = unwritable_dir(work)
    if problem is None:
        os.makedirs(work)
    return work, problem


def replace_dir(new: str, out: str) -> None:
    """Renames the finished directory `new` to `out` (`os.replace`), and removes the old
    `out` once the new one is in place."""
    old = new + "-old"
    shutil.rmtree(old, ignore_errors=True)
    if os.path.lexists(out):
        os.replace(out, old)
    os.replace(new, out)
    shutil.rmtree(old, ignore_errors=True)


def out_refusal(out: str, overwrite: bool) -> str | None:
    """Why a run may not write its results to the directory `out` (one line), or `None`:
    `out` is a file, or holds files and `overwrite` is not given, or can't be written.
    Creates nothing."""
    if os.path.exists(out) and not os.path.isdir(out):
        return f"--out {out!r} exists and is not a directory"
    if os.path.isdir(out) and os.listdir(out) and not overwrite:
        return f"--out {out!r} is not empty (--overwrite replaces it)"
    problem = unwritable_dir(os.path.dirname(os.path.abspath(out)))
    return f"--out {out!r} can't be written ({problem})" if problem else None


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


def summarize(
    config, env, prefs, j_ub, hv_ref, metrics, evaluation, timing, selection=None
) -> dict:
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
      timing: the whole sweep's clocks, over every part of a resumed one: `compile_s`,
        `train_s`, `wall_s`, `env_steps_timed` (the env steps `train_s` measured),
        `parts`, `timed_from_iteration` (the iteration they start from: 0 unless a part's
        clocks were lost).
      selection: with a choice among each preference's last policies, what
        `wcac_jax.sweep.selection` records of it (its `chosen_iteration` and `utopia`); each
        row's training metrics are then those of its chosen iteration.
    """
    n = prefs.shape[0]
    num_iterations = metrics["train/weights"].shape[1]
    # the iteration (a count of iterations done) whose policy each row reports
    iteration = [num_iterations] * n if selection is None else selection["chosen_iteration"]
    returns = np.asarray(evaluation["eval/return"])[:n]
    disc = np.asarray(evaluation["eval/discounted_return"])[:n]
    length = np.asarray(evaluation["eval/length"])[:n]
    nd = pareto.nondominated(returns)
    outside = pareto.outside_reference(returns, hv_ref)
    steps = int(metrics["train/env_steps"][0, -1])
    rows = []
    for i in range(n):
        t = iteration[i] - 1  # the metrics of the reported policy's last iteration
        rows.append(
            {
                "pref": prefs[i].tolist(),
                "return": returns[i].tolist(),
                "discounted_return": disc[i].tolist(),
                "episode_length": float(length[i]),
                "iteration": int(iteration[i]),
                "lambda": metrics["train/weights"][i, t].tolist(),
                "g_mu": float(metrics["train/g_mu"][i, t]),
                "scalarized": float(metrics["train/scalarized"][i, t]),
                "j_hat": metrics["train/j_hat"][i, t].tolist(),
                "train_episode_return": metrics["train/episode_return"][i, t].tolist(),
                "nondominated": bool(nd[i]),
                "inside_hv_ref": not bool(outside[i]),
            }
        )
        if "eval/x_velocity" in evaluation:  # an environment reporting its forward speed
            rows[-1]["mean_x_velocity"] = float(np.asarray(evaluation["eval/x_velocity"])[i])
    front = {
        "env": config.env,
        "objective_names": list(env.objective_names),
        # the utopia point in use at the end (the sweep's own estimate, if it made one)
        "j_ub": (
            metrics["train/utopia"][0, -1].tolist() if "train/utopia" in metrics else list(j_ub)
        ),
    }
    if selection is not None:  # what the choice among the last policies used
        front["selection_utopia"] = list(selection["utopia"])
        front["chosen_iteration"] = list(selection["chosen_iteration"])
    front.update(
        {
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
            # the whole sweep's clocks, summed over the parts of a resumed one
            "compile_s": timing["compile_s"],
            "train_s": timing["train_s"],
            "wall_s": timing["wall_s"],
            "parts": timing["parts"],
            "timed_from_iteration": timing["timed_from_iteration"],
            # training throughput (all preferences, compilation excluded): the env steps the
            # training clock measured, over it
            "env_steps_per_s": timing["env_steps_timed"] / max(timing["train_s"], 1e-9),
            "devices": [str(d) for d in jax.devices()],
            "versions": library_versions(),
            "config": config.to_dict(),
        }
    )
    if selection is not None:
        front["selection"] = selection
    return front


def write_outputs(out, front, metrics, prefs) -> None:
    """Writes `front.csv`, `curves.npz`, `front.png` and, last (it marks the sweep
    finished), `front.json` to `out`, each atomically."""
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
    from wcac_jax.sweep import plot

    fig = plot.plot_front(front)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=120)
    plot.plt.close(fig)
    write_atomic(os.path.join(out, "front.png"), png.getvalue())
    write_atomic(os.path.join(out, "front.json"), json_bytes(front))
