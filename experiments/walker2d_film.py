"""Films of a trained Walker2d front: every preference's deterministic policy walking (or
standing, or falling) side by side, to see what the numbers in `front.json` mean.

Reads a finished or interrupted Walker2d sweep (its last checkpoint, `load_sweep`; a
sweep that chose among its last policies, `--select-last`, its chosen ones), rolls
out each preference's deterministic policy for `--steps` steps from one start state per
preference (the sweep's seed; every preference its own), renders them with MuJoCo's
renderer and writes, into `--out` (default: the run's directory; created only once the
frames are drawn):

- `film.gif`: one panel per preference, all in step (every `--every`-th step, in real
  time: `dt = 0.008 s` per step), a fallen walker held where it fell;
- `film.png`: the same as a filmstrip, one row per preference, `--columns` moments;
- `film.json`: per preference `p`, the steps before falling (`length`), the distance the
  torso travelled (m) and its mean speed (m/s) over those steps.

    python -m wcac_jax.sweep --n-prefs 9 --out runs/front   # the README's first command
    python experiments/walker2d_film.py --run runs/front

Needs an OpenGL platform for MuJoCo's renderer: on a machine without a display, EGL
(`MUJOCO_GL=egl`, the default here) as on this repository's CPU machines.
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import tempfile

if not os.environ.get("DISPLAY"):  # MuJoCo reads it once, when first imported
    os.environ.setdefault("MUJOCO_GL", "egl")

import matplotlib  # noqa: E402

matplotlib.use("Agg")

import jax  # noqa: E402
import numpy as np  # noqa: E402
import walker2d_common as common  # noqa: E402
from matplotlib import animation  # noqa: E402
from script_io import refuse_existing  # noqa: E402

from wcac_jax import plot  # noqa: E402
from wcac_jax.evaluate import render  # noqa: E402
from wcac_jax.sweep import SweepError, load_sweep  # noqa: E402
from wcac_jax.sweep.outputs import json_bytes, unwritable_dir, write_atomic  # noqa: E402

FILES = ("film.gif", "film.png", "film.json")


def label(pref, speed: float) -> str:
    return "p = [" + ", ".join(f"{x:.3g}" for x in pref) + f"]  {speed:+.2f} m/s"


def write_gif(path: str, frames: np.ndarray, labels: list[str], fps: float) -> None:
    """`frames [P, T, H, W, 3]` as one animation of `P` panels."""
    n, steps = frames.shape[:2]
    cols = int(np.ceil(np.sqrt(n)))
    rows = int(np.ceil(n / cols))
    fig, axes = plot.plt.subplots(rows, cols, figsize=(2.4 * cols, 2.55 * rows), squeeze=False)
    images = []
    for i, ax in enumerate(axes.flat):
        ax.set_axis_off()
        if i < n:
            images.append(ax.imshow(frames[i, 0]))
            ax.set_title(labels[i], fontsize=8)
    fig.tight_layout(pad=0.3)

    def draw(t):
        for i, image in enumerate(images):
            image.set_data(frames[i, t])
        return images

    movie = animation.FuncAnimation(fig, draw, frames=steps, blit=True)
    # about one figure pixel per frame pixel (each panel is ~2.2 inches wide)
    dpi = frames.shape[3] / 2.2
    with tempfile.TemporaryDirectory() as scratch:  # Pillow writes to a named file
        gif = os.path.join(scratch, "film.gif")
        movie.save(gif, animation.PillowWriter(fps=fps), dpi=dpi)
        with open(gif, "rb") as f:
            write_atomic(path, f.read())
    plot.plt.close(fig)


def write_strip(path: str, frames: np.ndarray, labels: list[str], times: list[float]) -> None:
    """`frames [P, C, H, W, 3]`: one row per preference, one column per moment."""
    n, cols = frames.shape[:2]
    fig, axes = plot.plt.subplots(n, cols, figsize=(1.6 * cols, 1.75 * n), squeeze=False)
    for i in range(n):
        for j in range(cols):
            ax = axes[i, j]
            ax.imshow(frames[i, j])
            ax.set_xticks([]), ax.set_yticks([])
            if i == 0:
                ax.set_title(f"t = {times[j]:.1f} s", fontsize=8)
        axes[i, 0].set_ylabel(labels[i], fontsize=7)
    fig.tight_layout(pad=0.3)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=100)
    write_atomic(path, png.getvalue())
    plot.plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", required=True, help="a Walker2d sweep's output directory")
    parser.add_argument("--out", help="directory for the films (default: --run)")
    parser.add_argument("--steps", type=int, default=300, help="steps rolled out")
    parser.add_argument("--every", type=int, default=4, help="one GIF frame per N steps")
    parser.add_argument("--columns", type=int, default=6, help="moments in film.png")
    parser.add_argument("--size", type=int, default=160, help="panel size in pixels")
    parser.add_argument("--overwrite", action="store_true", help="replace films already in --out")
    args = parser.parse_args(argv)
    for flag in ("steps", "every", "columns", "size"):
        if getattr(args, flag) < 1:
            common.fail(f"--{flag} must be >= 1, got {getattr(args, flag)}")
    out = args.out or args.run
    problem = unwritable_dir(out)  # checked before any work; created once frames exist
    if problem:
        common.fail(f"--out {out!r} can't be written ({problem})")
    for name in FILES:  # refused before any work: another run's films stay as they are
        refuse_existing(os.path.join(out, name), args.overwrite, flag="")
    try:
        run = load_sweep(args.run)
    except SweepError as err:
        common.fail(str(err))
    if run.config.env != "walker2d":
        common.fail(f"--run {args.run!r} is a {run.config.env!r} sweep; films need walker2d")

    env = run.env
    n_prefs = len(run.config.prefs)
    keys = jax.random.split(jax.random.key(run.config.seed), n_prefs)
    rollout = jax.jit(jax.vmap(render.make_rollout(run.trainer, env, args.steps)))
    # the policies the front reports: with --select-last, each preference's chosen one
    policies = run.state if run.chosen is None else run.chosen
    qpos, length, fell = (np.asarray(x) for x in rollout(policies, keys))  # [P, T+1, nq], [P]
    physics = env.physics
    dt = float(env.dt)
    rows = []
    for i, pref in enumerate(run.config.prefs):
        distance = float(qpos[i, length[i], 0] - qpos[i, 0, 0])
        rows.append(
            {
                "pref": list(pref),
                "length": int(length[i]),
                "fell": bool(fell[i]),
                "distance_m": distance,
                "speed_m_per_s": distance / (max(int(length[i]), 1) * dt),
            }
        )
    labels = [label(r["pref"], r["speed_m_per_s"]) for r in rows]
    shown = np.arange(0, args.steps + 1, args.every)
    moments = np.linspace(0, args.steps, args.columns).round().astype(int)
    times = np.union1d(shown, moments)
    # every preference's frames in one call: one renderer (an OpenGL context) for all
    try:
        frames = render.render(
            env, qpos[:, times].reshape(-1, qpos.shape[-1]), args.size, args.size
        )
    except RuntimeError as err:
        common.fail(str(err), status=1)
    frames = frames.reshape(n_prefs, len(times), *frames.shape[1:])  # [P, frames, H, W, 3]
    try:  # only now: a run that could not render leaves no empty --out behind
        os.makedirs(out, exist_ok=True)
    except OSError as err:
        common.fail(f"--out {out!r} can't be created ({err.strerror})")
    index = {t: k for k, t in enumerate(times)}
    write_gif(
        os.path.join(out, "film.gif"),
        frames[:, [index[t] for t in shown]],
        labels,
        fps=1.0 / (dt * args.every),
    )
    write_strip(
        os.path.join(out, "film.png"),
        frames[:, [index[t] for t in moments]],
        labels,
        [t * dt for t in moments],
    )
    result = {
        "run": args.run,
        "physics": physics,
        "engine": env.backend,
        "steps": args.steps,
        "dt": dt,
        "policies": rows,
    }
    write_atomic(os.path.join(out, "film.json"), json_bytes(result))
    for r in rows:
        fell = f", fell at step {r['length']}" if r["fell"] else ""
        print(f"p = {r['pref']}: {r['distance_m']:.2f} m, {r['speed_m_per_s']:+.2f} m/s{fell}")
    print(f"wrote film.gif, film.png, film.json to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
