"""The MO-Gymnasium MuJoCo suite: each task's front with smooth_wc and with linear at the
task's default budget, a single-objective PPO reference per task, and the table that sets
them beside each other. The published numbers are set beside fronts trained under the
field's own protocols, on the same task definitions (`experiments/field.py`), not here:
these fronts train other budgets than the field's.

Three commands, each writing under `--results` (default `experiments/results/mo_mujoco`):

- `fronts`: for each task (`--envs`, default all), `python -m wcac_jax.sweep --env E
  --scalarization S --seed N` for S in `--directions` (default smooth_wc and linear),
  one compiled program each,
  into `<env>/<S>/` for seed 0 and `<env>/seed<N>/<S>/` for another seed (`front_dir`).
  `--smoke`: 3 preferences (the corners on 3 objectives), 20,480 env steps each, 1
  evaluation episode, to check the script end to end.
- `ppo`: the yardstick of one task, sbx PPO with `experiments/reference_ppo.py`'s settings
  (16 environments, 64 x 64, rollouts of 128, minibatches of 256, 10 epochs, Adam 3e-4,
  `VecNormalize`) on the task's own single-objective Gymnasium v5 reward
  (`Hopper-v5`, `HalfCheetah-v5`, `Swimmer-v5`, `Ant-v5`, `Humanoid-v5`, each with its
  default weights), the same episode length (500) and the same env-step budget per policy
  as a front's preference (`BUDGET`: 1M, the humanoid's 3M; `--steps` to change it); then
  its deterministic policy over 8 episodes. Writes
  `<env>/reference_ppo.json` (`mean_x_velocity` from Gymnasium's own `x_velocity`,
  `episode_length`, `wall_s`). sbx is not a dependency of wcac_jax: run this command
  with a Python that has `sbx-rl==0.28.0` and `gymnasium[mujoco]` (as `reference_ppo.py`
  says); it imports nothing of wcac_jax.
- `table`: reads every committed `front.json` and `reference_ppo.json` under
  `--results` and writes `table.md` and `table.json` (`summarize`, `write_table`): per
  task and scalarization the hypervolume under morl-baselines' convention (discounted
  returns, gamma 0.99, reference -100 per objective), expected utility, the
  non-dominated count, the forward end's mean speed against the reference's, and wall
  times. Where a task has both scalarizations' fronts on 3 or more seeds
  (`<env>/<S>/` and `<env>/seed<N>/<S>/`), `seeds` sets them side by side (`compare_seeds`):
  each seed's hypervolume, and a winner only where the two
  scalarizations' seed ranges do not overlap; per preference, each objective's mean
  return over the seeds, to say where on the front they differ. The seeds must share
  one setting (their `config.json` but for seed and scalarization): a task whose seeds
  were trained otherwise (a default changed in between) is refused, naming the fields.
  No number is typed here: all are read from those files.

Nothing is replaced by accident: `fronts` refuses a non-empty `<env>/<S>/` unless
`--resume` (the sweep continues it; a finished one is read, not rerun) or `--overwrite`
(the sweep replaces it whole when finished), and `ppo` and `table` refuse their existing
files unless `--overwrite`; each refusal before any work, exit 2 with one line naming the
path. Every file is written atomically.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time

from script_io import fail, refuse_existing

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "experiments", "results", "mo_mujoco")
SCALARIZATIONS = ("smooth_wc", "linear")
# each task's own single-objective Gymnasium v5 environment
SINGLE_OBJECTIVE = {
    "hopper": "Hopper-v5",
    "hopper-2obj": "Hopper-v5",
    "halfcheetah": "HalfCheetah-v5",
    "swimmer": "Swimmer-v5",
    "ant": "Ant-v5",
    "ant-2obj": "Ant-v5",
    "humanoid": "Humanoid-v5",
}
# each task's env-step budget per policy, its preset's (`wcac_jax.sweep.presets.ENV_DEFAULTS`,
# which a test holds this equal to; `ppo` runs in sbx's Python and imports nothing of
# wcac_jax): 3M for the humanoid, which walks at neither method's 1M
BUDGET = {env: 1_000_000 for env in SINGLE_OBJECTIVE} | {"humanoid": 3_000_000}
EPISODE_LENGTH = 500
MORL_BASELINES_GAMMA = 0.99
MORL_BASELINES_REF = -100.0


# ---------------------------------------------------------------------- fronts


def sweep_command(
    env: str, scalarization: str, out: str, seed: int, smoke: bool, flags=()
) -> list[str]:
    """The sweep command of one front (the task's default configuration and budget);
    `flags`: the sweep's `--resume` or `--overwrite`."""
    cmd = [sys.executable, "-m", "wcac_jax.sweep", "--env", env]
    cmd += ["--scalarization", scalarization, "--seed", str(seed), "--out", out]
    if smoke:
        cmd += ["--n-prefs", "3", "--steps-per-pref", "20480", "--eval-episodes", "1"]
    return cmd + list(flags)


def front_flags(out: str, resume: bool, overwrite: bool) -> list[str]:
    """The sweep flags for the front in `out`: none for a new one; for a non-empty one,
    `--resume` or `--overwrite` as asked, or a refusal."""
    if not (os.path.isdir(out) and os.listdir(out)):
        return []
    if overwrite:
        return ["--overwrite"]
    if resume:
        return ["--resume"]
    fail(f"{out!r} is not empty (--resume continues it, --overwrite replaces it)")


def front_dir(results: str, env: str, scalarization: str, seed: int = 0) -> str:
    """Where a front lives: `<env>/<S>` for seed 0 (the table's), `<env>/seed<N>/<S>`
    for another seed."""
    if seed == 0:
        return os.path.join(results, env, scalarization)
    return os.path.join(results, env, f"seed{seed}", scalarization)


def run_fronts(
    envs,
    results: str,
    seed: int,
    smoke: bool,
    resume=False,
    overwrite=False,
    directions=SCALARIZATIONS,
) -> int:
    if resume and overwrite:
        fail(f"--results {results!r}: --resume continues and --overwrite replaces: give one")
    outs = {(e, s): front_dir(results, e, s, seed) for e in envs for s in directions}
    # every front checked before the first is trained
    flags = {k: front_flags(out, resume, overwrite) for k, out in outs.items()}
    for env in envs:
        for scal in directions:
            out = outs[env, scal]
            cmd = sweep_command(env, scal, out, seed, smoke, flags[env, scal])
            print("+", " ".join(cmd[1:]), flush=True)
            code = subprocess.run(cmd, cwd=ROOT, env={**os.environ, "PYTHONPATH": ROOT}).returncode
            if code != 0:
                print(f"error: the {env} {scal} sweep exited with {code}", file=sys.stderr)
                return code
    return 0


# ---------------------------------------------------------------------- PPO reference


def run_ppo(env: str, out: str, steps: int, seed: int, eval_episodes: int) -> int:
    """One sbx PPO run on `env`'s single-objective v5 task; writes `out` (JSON)."""
    # the Walker2d yardstick's PPO and writer: as self-contained as this command
    from reference_ppo import make_ppo, write_atomic

    try:
        import gymnasium as gym
        import numpy as np
        import sbx  # noqa: F401  (make_ppo's; imported here for the one-line error)
    except ImportError as e:
        print(f"error: {e}; `ppo` needs sbx-rl and gymnasium[mujoco]", file=sys.stderr)
        return 2
    gym_id = SINGLE_OBJECTIVE[env]

    def make():
        return gym.make(gym_id, max_episode_steps=EPISODE_LENGTH)

    model, venv = make_ppo(make, seed)
    t0 = time.perf_counter()
    model.learn(total_timesteps=steps)
    wall_s = time.perf_counter() - t0
    single = make()
    speeds, lengths, returns = [], [], []
    for episode in range(eval_episodes):
        obs, _ = single.reset(seed=10_000 + episode)
        done, ret = False, 0.0
        while not done:
            action, _ = model.predict(venv.normalize_obs(obs[None]), deterministic=True)
            obs, reward, terminated, truncated, info = single.step(action[0])
            speeds.append(float(info["x_velocity"]))
            ret += float(reward)
            done = terminated or truncated
        lengths.append(len(speeds) - sum(lengths))
        returns.append(ret)
    result = {
        "env": env,
        "gym_id": gym_id,
        "episode_length_limit": EPISODE_LENGTH,
        "env_steps": steps,
        "seed": seed,
        "wall_s": wall_s,
        "mean_x_velocity": float(np.mean(speeds)),
        "episode_length": float(np.mean(lengths)),
        "return": float(np.mean(returns)),
        "eval_episodes": eval_episodes,
        "when": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
    }
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    write_atomic(out, json.dumps(result, indent=1).encode())
    print(json.dumps(result, indent=1))
    return 0


# ---------------------------------------------------------------------- the table


def _load(path: str):
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def _forward_end(front: dict) -> dict:
    """The row of the preference with the largest weight on the first objective."""
    return max(front["prefs"], key=lambda row: (row["pref"][0], -sum(row["pref"][1:])))


def summarize_front(env: str, front: dict, reference: dict | None) -> dict:
    """One row of the table from a `front.json` (and the task's PPO reference).

    Raises:
      ValueError: the reference ran another env-step budget than the front's per preference.
    """
    import numpy as np

    from wcac_jax import pareto

    m = len(front["objective_names"])
    gamma = front.get("config", {}).get("train", {}).get("gamma")
    disc = np.array([row["discounted_return"] for row in front["prefs"]], dtype=np.float64)
    end = _forward_end(front)
    row = {
        "env": env,
        "scalarization": front.get("config", {}).get("train", {}).get("scalarization"),
        "n_prefs": len(front["prefs"]),
        "env_steps_per_pref": front["env_steps_per_pref"],
        "gamma": gamma,
        "hv_morl_baselines": pareto.hypervolume(disc, [MORL_BASELINES_REF] * m),
        "expected_utility": front["expected_utility"],
        "nondominated": front["cardinality"],
        "forward_end_pref": end["pref"],
        "forward_end_mean_x_velocity": end.get("mean_x_velocity"),
        "forward_end_episode_length": end["episode_length"],
        "wall_s": front["wall_s"],
    }
    if reference is not None:
        # the same budget per policy: the front's as asked (its training rounds it up to
        # whole iterations), the reference's as run
        budget = front.get("config", {}).get("steps_per_pref", front["env_steps_per_pref"])
        if reference["env_steps"] != budget:
            raise ValueError(
                f"{env} {row['scalarization']}: the front trains {budget:,} env steps per "
                f"preference, its PPO reference {reference['env_steps']:,}: run `ppo --env "
                f"{env} --steps {budget}` to compare them at one budget"
            )
        speed, ref_speed = row["forward_end_mean_x_velocity"], reference["mean_x_velocity"]
        row["reference_mean_x_velocity"] = ref_speed
        row["reference_wall_s"] = reference["wall_s"]
        row["reference_env_steps"] = reference["env_steps"]
        row["speed_ratio"] = None if speed is None or ref_speed == 0 else speed / ref_speed
        # a whole front in one program against P separate runs, with a margin of 1.5
        row["wall_ratio"] = row["wall_s"] / (row["n_prefs"] * reference["wall_s"] / 1.5)
    return row


MIN_SEEDS = 3


def _seeds(results: str, env: str) -> list[int]:
    """The seeds with both scalarizations' fronts under `<results>/<env>`."""
    names = os.listdir(os.path.join(results, env))
    found = {0} | {int(name[4:]) for name in names if re.fullmatch(r"seed\d+", name)}
    return [
        seed
        for seed in sorted(found)
        if all(
            os.path.exists(os.path.join(front_dir(results, env, s, seed), "front.json"))
            for s in SCALARIZATIONS
        )
    ]


def _setting(front: dict) -> dict:
    """What a front was trained with, flattened, but for its seed and scalarization
    (empty for a front that does not record its configuration)."""
    config = front.get("config", {})
    flat = {k: v for k, v in config.items() if k not in ("train", "seed")}
    flat |= {f"train.{k}": v for k, v in config.get("train", {}).items() if k != "scalarization"}
    return flat


def compare_seeds(results: str, env: str) -> dict | None:
    """smooth_wc against linear on one task over the seeds with both fronts (None below
    `MIN_SEEDS`): per convention each seed's hypervolume, the mean, and the winner when
    the two seed ranges do not overlap (None where they do: the difference is within
    the seed-to-seed spread); per preference, each objective's mean undiscounted return
    over the seeds, and the forward end's mean speed."""
    import numpy as np

    seeds = _seeds(results, env)
    if len(seeds) < MIN_SEEDS:
        return None
    fronts = {
        s: [_load(os.path.join(front_dir(results, env, s, seed), "front.json")) for seed in seeds]
        for s in SCALARIZATIONS
    }
    prefs = [row["pref"] for row in fronts[SCALARIZATIONS[0]][0]["prefs"]]
    setting = _setting(fronts[SCALARIZATIONS[0]][0])
    for s in SCALARIZATIONS:
        for seed, front in zip(seeds, fronts[s], strict=True):
            if [row["pref"] for row in front["prefs"]] != prefs:
                raise ValueError(f"{env} {s} seed {seed}: other preferences than seed {seeds[0]}'s")
            if (own := _setting(front)) != setting:
                diff = sorted(
                    k for k in setting.keys() | own.keys() if setting.get(k) != own.get(k)
                )
                raise ValueError(
                    f"{env} {s} seed {seed}: trained otherwise than {SCALARIZATIONS[0]} seed "
                    f"{seeds[0]} ({', '.join(diff)}); the seeds compare one setting"
                )
    rows = {s: [summarize_front(env, f, None) for f in fronts[s]] for s in SCALARIZATIONS}

    def side_by_side(key: str) -> dict:
        entry = {s: [r[key] for r in rows[s]] for s in SCALARIZATIONS}
        entry["mean"] = {s: float(np.mean(entry[s])) for s in SCALARIZATIONS}
        (a, b), (name_a, name_b) = (entry[s] for s in SCALARIZATIONS), SCALARIZATIONS
        entry["winner"] = name_a if min(a) > max(b) else name_b if min(b) > max(a) else None
        return entry

    return {
        "seeds": seeds,
        "prefs": prefs,
        "hypervolume": {"hv_morl_baselines": side_by_side("hv_morl_baselines")},
        "forward_speed": side_by_side("forward_end_mean_x_velocity"),
        "mean_return": {
            s: np.mean([[row["return"] for row in f["prefs"]] for f in fronts[s]], axis=0).tolist()
            for s in SCALARIZATIONS
        },
    }


def summarize(results: str) -> dict:
    """Every task's rows (one per scalarization found) and their seeds compared."""
    rows = []
    for env in sorted(os.listdir(results)) if os.path.isdir(results) else []:
        reference = _load(os.path.join(results, env, "reference_ppo.json"))
        for scal in SCALARIZATIONS:
            front = _load(os.path.join(results, env, scal, "front.json"))
            if front is not None:
                rows.append(summarize_front(env, front, reference))
    envs = sorted({row["env"] for row in rows})
    seeds = {env: c for env in envs if (c := compare_seeds(results, env)) is not None}
    return {
        "conventions": {
            "hv_morl_baselines": f"discounted returns (gamma {MORL_BASELINES_GAMMA}), "
            f"reference {MORL_BASELINES_REF} per objective",
        },
        "rows": rows,
        "seeds": seeds,
    }


def _fmt(x, spec: str = ".4g") -> str:
    if x is None:
        return "-"
    if isinstance(x, list):
        return "(" + ", ".join(_fmt(v, ".3g") for v in x) + ")"
    return format(x, spec)


def seed_lines(seeds: dict) -> list[str]:
    """table.md's section of `compare_seeds`, task by task."""
    names = {"hv_morl_baselines": "HV (morl-baselines)"}
    lines = ["", "## smooth_wc against linear over seeds", ""]
    if not seeds:
        return lines + [f"No task has both fronts on {MIN_SEEDS} or more seeds yet."]
    lines += [
        "Each seed's front at the task's default; a winner only where the two seed ranges "
        "do not overlap (otherwise: within the seed-to-seed spread).",
    ]
    a, b = SCALARIZATIONS
    for env, c in seeds.items():
        lines += [
            "",
            f"### {env} (seeds {', '.join(map(str, c['seeds']))})",
            "",
            f"| measure | {a}, per seed | {a}, mean | {b}, per seed | {b}, mean | winner |",
            "|---|---|---|---|---|---|",
        ]
        entries = [(names[k], e) for k, e in c["hypervolume"].items()]
        for name, e in entries + [("forward end's speed (m/s)", c["forward_speed"])]:
            lines.append(
                f"| {name} | {', '.join(_fmt(v) for v in e[a])} | {_fmt(e['mean'][a])} "
                f"| {', '.join(_fmt(v) for v in e[b])} | {_fmt(e['mean'][b])} "
                f"| {e['winner'] or 'within the spread'} |"
            )
        lines += [
            "",
            "Mean undiscounted return over the seeds, per preference:",
            "",
            f"| preference | {a} | {b} |",
            "|---|---|---|",
        ]
        for pref, ra, rb in zip(c["prefs"], c["mean_return"][a], c["mean_return"][b], strict=True):
            lines.append(f"| {_fmt(pref)} | {_fmt(ra)} | {_fmt(rb)} |")
    return lines


def write_table(summary: dict, results: str) -> None:
    """`table.md` and `table.json` under `results`."""
    lines = [
        "# The MO-Gymnasium MuJoCo suite: fronts and PPO references",
        "",
        "Written by `python experiments/mo_mujoco.py table` from the `front.json` and "
        "`reference_ppo.json` files beside this table.",
        "",
        f"- HV (morl-baselines): {summary['conventions']['hv_morl_baselines']}.",
        "- speed ratio: the forward end's mean x velocity over the PPO reference's; wall "
        "ratio: the front's wall time over P x the reference's / 1.5 (below 1: the front "
        "in one program beats P separate PPO runs by the margin).",
        "",
        "| task | scalarization | P | steps/pref | gamma | HV (morl-baselines) "
        "| EU | non-dominated | forward end | its speed (m/s) | PPO speed (m/s) | speed "
        "ratio | wall (s) | PPO wall (s) | wall ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["rows"]:
        lines.append(
            f"| {r['env']} | {r['scalarization']} | {r['n_prefs']} "
            f"| {r['env_steps_per_pref']:,} | {_fmt(r['gamma'])} "
            f"| {_fmt(r['hv_morl_baselines'])} "
            f"| {_fmt(r['expected_utility'])} | {r['nondominated']} "
            f"| {_fmt(r['forward_end_pref'])} | {_fmt(r['forward_end_mean_x_velocity'], '.3f')} "
            f"| {_fmt(r.get('reference_mean_x_velocity'), '.3f')} "
            f"| {_fmt(r.get('speed_ratio'), '.2f')} | {_fmt(r['wall_s'], '.0f')} "
            f"| {_fmt(r.get('reference_wall_s'), '.0f')} | {_fmt(r.get('wall_ratio'), '.2f')} |"
        )
    lines += seed_lines(summary["seeds"])
    lines += [
        "",
        "Published numbers: beside fronts trained under the field's protocols on the same "
        "task definitions, in `experiments/results/field/` (`experiments/field.py`).",
    ]
    from wcac_jax.sweep.outputs import write_atomic

    os.makedirs(results, exist_ok=True)
    write_atomic(os.path.join(results, "table.md"), ("\n".join(lines) + "\n").encode())
    write_atomic(os.path.join(results, "table.json"), json.dumps(summary, indent=1).encode())


# ---------------------------------------------------------------------- command line


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("command", choices=("fronts", "ppo", "table"))
    parser.add_argument("--envs", default=",".join(SINGLE_OBJECTIVE), help="fronts: tasks")
    parser.add_argument(
        "--directions",
        default=",".join(SCALARIZATIONS),
        help="fronts: the scalarizations, comma-separated (default both)",
    )
    parser.add_argument("--env", default=None, help="ppo: the task")
    parser.add_argument("--results", default=RESULTS, help="results directory")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--smoke", action="store_true", help="a tiny budget, end to end")
    parser.add_argument(
        "--steps",
        type=int,
        default=None,
        help="ppo: env steps (default the task's budget per preference: 1M, the humanoid 3M)",
    )
    parser.add_argument("--eval-episodes", type=int, default=8, help="ppo: evaluation episodes")
    parser.add_argument(
        "--resume", action="store_true", help="fronts: continue the fronts already there"
    )
    parser.add_argument(
        "--overwrite", action="store_true", help="replace the results already there"
    )
    args = parser.parse_args(argv)
    if args.command == "fronts":
        envs = [e for e in args.envs.split(",") if e]
        unknown = [e for e in envs if e not in SINGLE_OBJECTIVE]
        if unknown:
            parser.error(f"unknown task(s) {unknown}; valid: {', '.join(SINGLE_OBJECTIVE)}")
        directions = [d for d in args.directions.split(",") if d]
        bad = [d for d in directions if d not in SCALARIZATIONS]
        if bad or not directions:
            parser.error(f"--directions {args.directions!r}: valid: {', '.join(SCALARIZATIONS)}")
        return run_fronts(
            envs, args.results, args.seed, args.smoke, args.resume, args.overwrite, directions
        )
    if args.command == "ppo":
        if args.env not in SINGLE_OBJECTIVE:
            parser.error(f"ppo needs --env, one of {', '.join(SINGLE_OBJECTIVE)}")
        steps = BUDGET[args.env] if args.steps is None else args.steps
        steps, episodes = (4096, 1) if args.smoke else (steps, args.eval_episodes)
        out = os.path.join(args.results, args.env, "reference_ppo.json")
        refuse_existing(out, args.overwrite, flag="")
        return run_ppo(args.env, out, steps, args.seed, episodes)
    for name in ("table.md", "table.json"):
        path = os.path.join(args.results, name)
        refuse_existing(path, args.overwrite, flag="")
    sys.path.insert(0, ROOT)
    try:
        summary = summarize(args.results)
    except ValueError as e:  # fronts that cannot be set side by side: nothing written
        fail(str(e))
    write_table(summary, args.results)
    print(f"wrote {args.results}/table.md and table.json: {len(summary['rows'])} fronts")
    return 0


if __name__ == "__main__":
    sys.exit(main())
