"""What a sweep is, `SweepConfig`, and the checks of its input (preferences, environment,
reference point, output directory), each failing as a `SweepError` that names the value."""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import jax
import numpy as np

from wcac_jax import envs, protocols
from wcac_jax.algos import PaperConfig, UpdateConfig, from_dict, to_dict
from wcac_jax.sweep import selection
from wcac_jax.sweep.outputs import json_bytes, unwritable_dir

PAPER_STEPS_PER_PREF = 1_000_000
MAX_ITERATIONS = 2**31 - 1  # `UpdateState.iteration` is int32


class SweepError(ValueError):
    """Bad input to a sweep; the CLI prints it as one line and exits with status 2."""


@dataclass(frozen=True)
class SweepConfig:
    """Everything that determines a sweep's numbers.

    Attributes:
      prefs: `P` preference vectors, each on the simplex.
      env: registered environment name.
      env_options: keyword options of the environment (e.g. `physics`).
      train: the per-preference training configuration, the paper's (`PaperConfig`)
        or the practical one (`PracticalConfig`); its `num_iterations` is derived from
        `steps_per_pref`.
      steps_per_pref: environment steps per preference (rounded up to whole iterations).
      seed: base seed; preference `i` uses `fold_in(key(seed), i)`.
      eval_episodes: episodes of the mean policy evaluated per preference at the end.
      hv_ref: hypervolume reference point (`None`: the environment's default).
      device_count: devices the preference axis is sharded over (`None`: every device
        JAX has; `run_sweep` records the count it used). Results are bit-identical for
        the same config, device count included, and any chunking; across device counts
        they differ by rounding (XLA compiles different per-device batch shapes).
      select_last: each preference reports the best of its last `select_last` policies
        (`wcac_jax.sweep.selection`; 1: the final policy, no choice).
      select_every: environment steps between those candidates (rounded up to whole
        iterations; needed when `select_last > 1`).
      protocol: the benchmark protocol the front is scored under besides the project's
        own metrics (`wcac_jax.protocols`; `None`: none). `env` must be one of its tasks.
    """

    prefs: tuple[tuple[float, ...], ...]
    env: str = "walker2d"
    env_options: dict = field(default_factory=dict)
    train: UpdateConfig = field(default_factory=PaperConfig)
    steps_per_pref: int = 100_000
    seed: int = 0
    eval_episodes: int = 8
    hv_ref: tuple[float, ...] | None = None
    device_count: int | None = None
    select_last: int = 1
    select_every: int = 0
    protocol: str | None = None

    def __post_init__(self):
        if self.env in envs.EARLIER_DEFAULTS:  # recorded whole: their default has changed
            now = envs.option_defaults(self.env)
            changed = {k: now[k] for k in envs.EARLIER_DEFAULTS[self.env]}
            object.__setattr__(self, "env_options", {**changed, **self.env_options})
        for name in ("steps_per_pref", "eval_episodes", "select_last"):
            value = getattr(self, name)
            if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < 1:
                raise SweepError(f"{name} must be a positive integer, got {value!r}")
        if self.num_iterations > MAX_ITERATIONS:
            raise SweepError(
                f"steps_per_pref {self.steps_per_pref} needs {self.num_iterations:,} iterations of "
                f"{self.train.env_steps_per_iteration:,} env steps; at most {MAX_ITERATIONS:,} "
                "(the iteration counter is int32)"
            )
        if not isinstance(self.seed, int | np.integer) or not -(2**63) <= self.seed < 2**63:
            raise SweepError(f"seed must be an integer in [-2**63, 2**63), got {self.seed!r}")
        if self.hv_ref is not None:
            try:
                hv_ref = tuple(float(v) for v in self.hv_ref)
            except (TypeError, ValueError):
                raise SweepError(f"hv_ref must be a list of numbers, got {self.hv_ref!r}") from None
            if not all(math.isfinite(v) for v in hv_ref):
                raise SweepError(f"hv_ref must be finite, got {list(hv_ref)}")
            object.__setattr__(self, "hv_ref", hv_ref)
        every = self.select_every
        if not isinstance(every, int | np.integer) or isinstance(every, bool) or every < 0:
            raise SweepError(f"select_every must be a non-negative integer, got {every!r}")
        if self.select_last > 1 and every < 1:
            raise SweepError(
                f"select_last {self.select_last} needs select_every >= 1 (env steps between "
                f"the candidates), got {every}"
            )
        try:
            self.candidate_iterations  # noqa: B018 (validates)
        except ValueError as err:
            raise SweepError(str(err)) from None
        if self.protocol is not None:
            try:
                protocols.get(self.protocol).task(self.env)
            except ValueError as err:
                raise SweepError(str(err)) from None

    @property
    def num_iterations(self) -> int:
        """Outer iterations `T` per preference."""
        return max(1, math.ceil(self.steps_per_pref / self.train.env_steps_per_iteration))

    @property
    def candidate_iterations(self) -> tuple[int, ...]:
        """The iterations whose policies `wcac_jax.sweep.selection` chooses among."""
        every = math.ceil(self.select_every / self.train.env_steps_per_iteration)
        return selection.candidate_iterations(self.num_iterations, self.select_last, every)

    def train_config(self) -> UpdateConfig:
        return self.train.replace(num_iterations=self.num_iterations)

    def to_dict(self) -> dict:
        """The config as JSON-ready data (`protocol` only when one is set, so a sweep
        without one writes the same `config.json` as before protocols existed)."""
        out = {
            "prefs": [list(p) for p in self.prefs],
            "env": self.env,
            "env_options": dict(self.env_options),
            "train": to_dict(self.train_config()),
            "steps_per_pref": self.steps_per_pref,
            "seed": self.seed,
            "eval_episodes": self.eval_episodes,
            "hv_ref": None if self.hv_ref is None else list(self.hv_ref),
            "device_count": self.device_count,
            "select_last": self.select_last,
            "select_every": self.select_every,
        }
        if self.protocol is not None:
            out["protocol"] = self.protocol
        return out

    @classmethod
    def from_dict(cls, d: dict) -> SweepConfig:
        """The inverse of `to_dict` (e.g. a run's `config.json`), reading what older
        runs recorded as they ran (`algos.from_dict`, `envs.EARLIER_DEFAULTS`)."""
        return cls(
            prefs=tuple(tuple(float(x) for x in p) for p in d["prefs"]),
            env=d["env"],
            # an option it did not record ran with the default of its day
            env_options={**envs.EARLIER_DEFAULTS.get(d["env"], {}), **d["env_options"]},
            train=from_dict(d["train"]),
            steps_per_pref=int(d["steps_per_pref"]),
            seed=int(d["seed"]),
            eval_episodes=int(d["eval_episodes"]),
            hv_ref=None if d["hv_ref"] is None else tuple(d["hv_ref"]),
            device_count=d.get("device_count"),
            select_last=int(d.get("select_last", 1)),
            select_every=int(d.get("select_every", 0)),
            protocol=d.get("protocol"),
        )


def validate_prefs(prefs, m: int) -> np.ndarray:
    """Checks `P` preference vectors: length `m`, finite, non-negative, summing to 1
    within 1e-6 (they are not normalised, so that what runs is what was asked for)."""
    if len(prefs) < 1:
        raise SweepError(f"preferences must be a non-empty list of vectors, got {prefs!r}")
    for i, p in enumerate(prefs):
        p = np.asarray(p, dtype=np.float64).reshape(-1)
        if p.shape[0] != m:
            raise SweepError(
                f"preference #{i} {p.tolist()} has {p.shape[0]} entries; "
                f"the environment has {m} objectives"
            )
        if not np.all(np.isfinite(p)):
            raise SweepError(f"preference #{i} {p.tolist()} is not finite")
        if np.any(p < 0):
            raise SweepError(f"preference #{i} {p.tolist()} has a negative entry")
        if abs(p.sum() - 1.0) > 1e-6:
            raise SweepError(f"preference #{i} {p.tolist()} sums to {p.sum():.6g}, not 1")
    return np.asarray(prefs, dtype=np.float64)


def default_hv_ref(env) -> tuple[float, ...]:
    """The environment's hypervolume reference point, `env.default_hv_ref`.

    The rule every environment follows: per objective, the least return an episode can
    have (for an unbounded objective, a stated floor far below any return seen), so that
    every policy's point lies in the reference box and counts; `front.json` lists any
    policy that does not (`outside_hv_ref`).
    """
    ref = getattr(env, "default_hv_ref", None)
    if ref is None:
        raise SweepError(
            f"environment {type(env).__name__} has no default_hv_ref; pass hv_ref (--hv-ref)"
        )
    return tuple(float(v) for v in ref)


def make_env(config: SweepConfig):
    """The environment of `config`; a bad name or option is a `SweepError`."""
    try:
        return envs.make(config.env, **config.env_options)
    except (ValueError, TypeError) as err:
        raise SweepError(str(err)) from None


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def read_json(path: str, context: str, what: str) -> dict | None:
    """The JSON object in `path`, or `None` if there is no such file.

    Raises:
      SweepError: naming `context` (what needed it), when `path` is not readable JSON or
        holds no object (`what` it should hold, e.g. "sweep config").
    """
    if not os.path.isfile(path):
        return None
    try:
        with open(path) as f:
            saved = json.load(f)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise SweepError(f"{context}{path!r} is not readable JSON ({err})") from None
    if not isinstance(saved, dict):
        raise SweepError(f"{context}{path!r} holds no {what} (a {type(saved).__name__})")
    return saved


def read_config(out: str, context: str = "--resume") -> SweepConfig:
    """The sweep `out` holds, read from its `config.json` (`SweepConfig.from_dict`).

    Raises:
      SweepError: naming `context` (what needed it; "" for none) and why it can't be read.
    """
    prefix = f"{context}: " if context else ""
    path = os.path.join(out, "config.json")
    saved = read_json(path, prefix, "sweep config")
    if saved is None:
        raise SweepError(f"{prefix}no sweep in {out!r} (no config.json)")
    try:
        return SweepConfig.from_dict(saved)
    except (KeyError, TypeError, ValueError) as err:
        raise SweepError(f"{prefix}{path!r} holds no readable sweep config ({err!r})") from None


def check_output_dir(out: str, config: SweepConfig, resume: bool, overwrite: bool = False) -> None:
    """Checks `out` can be written (creating nothing); on resume, that `config` is the
    sweep `out` holds (`read_config`). A non-empty `out` is refused unless `resume`
    (continue its sweep) or `overwrite` (replace it, `run_sweep`: through a directory
    beside it, so its parent must be writable)."""
    if resume:
        saved = _flatten(json.loads(json_bytes(read_config(out).to_dict())))
        new = _flatten(json.loads(json_bytes(config.to_dict())))
        if saved.get("device_count") is None:  # written before the device count was recorded
            new.pop("device_count", None)
            saved.pop("device_count", None)
        elif new.get("device_count") is None:  # `None`: every device, as `run_sweep` fills in
            new["device_count"] = jax.device_count()
        differ = sorted(k for k in set(saved) | set(new) if saved.get(k) != new.get(k))
        if differ:  # at most three named
            details = ", ".join(
                f"{k} (saved {saved.get(k)!r}, now {new.get(k)!r})" for k in differ[:3]
            )
            more = f" and {len(differ) - 3} more" if len(differ) > 3 else ""
            raise SweepError(f"--resume: the config in {out!r} differs: {details}{more}")
        for path in (out, os.path.join(out, "checkpoint")):
            if os.path.exists(path) and not os.access(path, os.W_OK | os.X_OK):
                raise SweepError(f"--resume: {path!r} is not writable")
        return
    if os.path.exists(out):
        if not os.path.isdir(out):
            raise SweepError(f"--out {out!r} exists and is not a directory")
        if os.listdir(out) and not overwrite:
            raise SweepError(
                f"--out {out!r} is not empty (--resume continues its sweep, --overwrite "
                "replaces it)"
            )
        if overwrite:  # the new run is written beside `out`, then renamed over it
            problem = unwritable_dir(os.path.dirname(os.path.abspath(out)))
            if problem:
                raise SweepError(f"--overwrite: --out {out!r} can't be replaced ({problem})")
            return
        if not os.access(out, os.W_OK | os.X_OK):
            raise SweepError(f"--out {out!r} is not writable")
        return
    problem = unwritable_dir(out)
    if problem:
        raise SweepError(f"--out {out!r} can't be written ({problem})")
