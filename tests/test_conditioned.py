"""The preference-conditioned update: its pieces by hand, its advantage against the
practical update's for each environment's own preference, and one network's front on
the concave bandit."""

import json
import os
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import algos, envs, pareto, runtime, scalarize, sweep, utopia
from wcac_jax.algos import conditioned, practical
from wcac_jax.envs import concave_bandit
from wcac_jax.sweep import cli


def test_registered_as_its_own_kind():
    config = conditioned.ConditionedConfig()
    assert algos.kind(config) == "conditioned"
    assert algos.kind(practical.PracticalConfig()) == "practical"
    assert algos.from_dict(algos.to_dict(config)) == config


def test_episode_start_obs_follows_episode_boundaries():
    # one environment, L = 5, obs = [t]; episodes end at transitions 1 and 3
    first = jnp.array([-1.0])
    obs = jnp.arange(5.0)[:, None]
    done = jnp.array([0.0, 1.0, 0.0, 1.0, 0.0])
    starts = conditioned.episode_start_obs(first, obs, done)
    # transitions 0-1 belong to the episode in progress, 2-3 start at obs 2, 4 at obs 4
    np.testing.assert_array_equal(starts[:, 0], [-1.0, -1.0, 2.0, 2.0, 4.0])


def test_scalarized_advantage_linear_by_hand():
    # linear: w = 1, so c = p * sigma
    adv = jnp.array([2.0, -1.0])
    pref = jnp.array([0.25, 0.75])
    sigma = jnp.array([2.0, 4.0])
    got, weights = conditioned.scalarized_advantage(
        adv, jnp.zeros(2), pref, jnp.zeros(2), sigma, 1.0, "linear"
    )
    np.testing.assert_array_equal(weights, [1.0, 1.0])
    assert float(got) == pytest.approx(2.0 * 0.25 * 2.0 + (-1.0) * 0.75 * 4.0)


@pytest.mark.parametrize("augment", [0.0, 0.05])
def test_advantage_equals_the_practical_update_env_by_env(augment):
    """Each environment's scalarized advantage is what the practical update computes for
    a preference at that environment's own: the weights `practical._scalarize` gives at
    its `Jhat` and the shared utopia point, times p (plus rho), times sigma, dotted with
    the GAE vector; and, by hand, lambda = softmax(p (z - Jhat) / mu)."""
    rng = np.random.default_rng(0)
    n, m, mu = 4, 2, 0.7
    adv = jnp.asarray(rng.normal(size=(n, m)), jnp.float32)
    j_hat = jnp.asarray(rng.normal(size=(n, m)) * 5, jnp.float32)
    prefs = jnp.asarray(rng.dirichlet(np.ones(m), size=n), jnp.float32)
    sigma = jnp.asarray([1.5, 0.5], jnp.float32)
    z = jnp.max(j_hat, axis=0) + 1.0
    index = runtime.TRACED_DIRECTIONS.index("smooth_wc")
    got, weights = jax.vmap(
        lambda a, j, p: conditioned.scalarized_advantage(a, j, p, z, sigma, mu, index, augment)
    )(adv, j_hat, prefs)
    config = practical.PracticalConfig(mu=mu, utopia="fixed", augment=augment)
    parts = SimpleNamespace(config=config, j_ub=z)
    state = SimpleNamespace(utopia=utopia.init(m))
    for i in range(n):
        _, _, w, _ = practical._scalarize(parts, state, j_hat[i], prefs[i], None)
        coeff = scalarize.augmented_coefficients(w, prefs[i], augment) * sigma
        assert float(got[i]) == pytest.approx(float(adv[i] @ coeff), rel=1e-6)
        regret = np.asarray(prefs[i] * (z - j_hat[i]), np.float64)
        lam = np.exp(regret / mu - np.max(regret / mu))
        lam /= lam.sum()
        np.testing.assert_allclose(weights[i], lam, rtol=1e-5)
        want = np.asarray(adv[i]) @ ((lam * np.asarray(prefs[i]) + augment) * np.asarray(sigma))
        assert float(got[i]) == pytest.approx(float(want), rel=1e-5)


def test_utopia_from_the_preferences_in_play():
    j_hat = jnp.array([[[1.0, 5.0], [3.0, 2.0]]])  # [L=1, N=2, m=2]
    config = conditioned.ConditionedConfig(utopia_margin=0.5, utopia_min_spread=1.0)
    state, z = conditioned.estimate_utopia(config, utopia.init(2), j_hat)
    np.testing.assert_allclose(state.best, [3.0, 5.0])
    # z = best + margin * max(best - least, min_spread)
    np.testing.assert_allclose(z, [3.0 + 0.5 * 2.0, 5.0 + 0.5 * 3.0])
    # the best so far is kept
    state, z = conditioned.estimate_utopia(config, state, j_hat - 10.0)
    np.testing.assert_allclose(state.best, [3.0, 5.0])


def test_preference_conditioned_env_appends_and_keeps_the_preference():
    env = envs.make("concave_bandit")
    fixed = jnp.array([0.3, 0.7], jnp.float32)
    cenv = conditioned.PreferenceConditioned(env, lambda key: fixed)
    state = cenv.reset(jax.random.PRNGKey(0))
    assert cenv.observation_size == env.observation_size + 2
    np.testing.assert_array_equal(state.obs[-2:], fixed)
    nxt = cenv.step(state, jnp.zeros(env.action_size))
    np.testing.assert_array_equal(nxt.obs[-2:], fixed)
    drawn = jax.vmap(conditioned.dirichlet_preference(3))(jax.random.split(jax.random.key(1), 64))
    np.testing.assert_allclose(jnp.sum(drawn, axis=1), 1.0, atol=1e-6)
    assert float(jnp.min(drawn)) >= 0.0


def test_every_episode_carries_its_own_preference_through_auto_resets():
    """The time limit's auto-reset draws the next episode's preference, and every step of
    that episode carries it, not the preference the environment started with."""
    env = envs.make("deep_sea_treasure", episode_length=3)
    cenv = conditioned.PreferenceConditioned(env, conditioned.dirichlet_preference(2))
    venv = runtime.vectorize(cenv)
    state = venv.reset(jax.random.split(jax.random.key(0), 4))
    seen = []
    for _ in range(9):  # three episodes of three steps (moving left at the left edge)
        seen.append(np.asarray(state.obs[:, -2:]))
        state = venv.step(state, jnp.full((4,), 2, jnp.int32))
        assert float(jnp.max(state.info["terminal"])) == 0.0
    seen = np.stack(seen)  # [9, N, 2]
    for episode in range(3):
        steps = seen[3 * episode : 3 * episode + 3]
        np.testing.assert_array_equal(steps, np.broadcast_to(steps[0], steps.shape))
    assert not np.any(np.isclose(seen[0], seen[3])) and not np.any(np.isclose(seen[3], seen[6]))


def test_each_environment_keeps_one_preference_for_the_run():
    """With `keep` (`pref_draw="environment"`), every step of every episode of an
    environment carries the preference of its first reset, the first step of a new
    episode too; the environments' preferences differ."""
    env = envs.make("deep_sea_treasure", episode_length=3)
    cenv = conditioned.PreferenceConditioned(env, conditioned.dirichlet_preference(2), keep=True)
    venv = runtime.vectorize(cenv)
    state = venv.reset(jax.random.split(jax.random.key(0), 4))
    first = np.asarray(state.obs[:, -2:])
    for _ in range(9):  # three episodes of three steps
        state = venv.step(state, jnp.full((4,), 2, jnp.int32))
        np.testing.assert_array_equal(state.obs[:, -2:], first)
        np.testing.assert_array_equal(state.info["pref"], first)
        np.testing.assert_array_equal(state.info["first_obs"][:, -2:], first)
    assert float(jnp.sum(state.done)) == 4.0  # the ninth step ended the third episodes
    assert len({tuple(p) for p in first.tolist()}) == 4


def test_config_draws_a_preference_per_episode_or_per_environment():
    assert conditioned.ConditionedConfig().pref_draw == "episode"
    with pytest.raises(ValueError, match="pref_draw"):
        conditioned.ConditionedConfig(pref_draw="run")


@pytest.mark.parametrize(
    "alpha, variance, below_tenth",
    # each of two components is Beta(alpha, alpha): variance 1 / (4 (2 alpha + 1));
    # P(p_1 < 0.1) is 0.1 when uniform, (2 / pi) asin(sqrt(0.1)) = 0.2048 at 0.5, and at
    # 0.05 the regularised incomplete beta I_0.1(0.05, 0.05) = 0.4495 (t = u^20 turns
    # its integral into a smooth one: 20 int_0^(0.1^0.05) (1 - u^20)^(-0.95) du over
    # Gamma(0.05)^2 / Gamma(0.1))
    [(1.0, 1 / 12, 0.1), (0.5, 1 / 8, 0.2048), (0.05, 1 / 4.4, 0.4495)],
)
def test_dirichlet_preference_concentration_by_hand(alpha, variance, below_tenth):
    """A concentration below 1 draws preferences toward the simplex's corners (the
    front's ends), with the Beta marginals' moments."""
    n = 40_000
    drawn = jax.vmap(conditioned.dirichlet_preference(2, alpha))(
        jax.random.split(jax.random.key(2), n)
    )
    p1 = np.asarray(drawn[:, 0], np.float64)
    np.testing.assert_allclose(np.asarray(jnp.sum(drawn, axis=1)), 1.0, atol=1e-6)
    # within 5 standard errors: the variance estimate's is variance * sqrt((k - 1) / n),
    # Beta(alpha, alpha)'s kurtosis k = 3 - 6 / (2 alpha + 3); the frequency's
    # sqrt(q (1 - q) / n)
    kurtosis = 3.0 - 6.0 / (2.0 * alpha + 3.0)
    assert abs(p1.mean() - 0.5) < 5 * np.sqrt(variance / n)
    assert abs(p1.var() - variance) < 5 * variance * np.sqrt((kurtosis - 1.0) / n)
    q = np.mean(p1 < 0.1)
    assert abs(q - below_tenth) < 5 * np.sqrt(below_tenth * (1 - below_tenth) / n)


# a fixed small policy noise (a stochastic policy's front on the bandit is the convex
# hull: the ends), a sharp mu for its values in [0, 1], the fixed utopia point
BANDIT = conditioned.ConditionedConfig(
    num_envs=64,
    rollout_steps=2,
    num_iterations=200,
    num_epochs=4,
    num_minibatches=2,
    width=32,
    depth=1,
    mu=0.01,
    utopia="fixed",
    normalize_obs=False,
    learning_rate=3e-3,
    learn_log_std=False,
    log_std_init=-3.0,
)
BANDIT_PREFS = np.array([[0.6, 0.4], [0.5, 0.5], [0.4, 0.6]], np.float32)


@pytest.fixture(
    scope="module",
    params=[(1.0, False), (0.5, False), (0.05, False), (1.0, True)],
    ids=["uniform", "dirichlet0.5", "dirichlet0.05", "log-std-by-pref"],
)
def bandit_front(request):
    """One network trained on the concave bandit, its preferences drawn uniformly and
    toward the simplex's corners (Dirichlet(0.5), PGMORL's walker's draw; Dirichlet(0.05),
    COLA's half-cheetah's, 4 in 5 within 0.01 of an end), and with the policy's log-std a
    function of the preference (`log_std_by_pref`), evaluated at `BANDIT_PREFS`: `[3, 2]`
    returns."""
    alpha, by_pref = request.param
    config = BANDIT.replace(pref_alpha=alpha, log_std_by_pref=by_pref)
    env = envs.make("concave_bandit")
    trainer = algos.make_trainer(config, env)
    evaluate_at = conditioned.make_evaluate_at(config, env, 1, trainer)

    @jax.jit
    def program(key, prefs):
        pref = jnp.full((2,), 0.5)
        state, _ = trainer.run(trainer.init(key, pref), pref, config.num_iterations)
        return jax.vmap(evaluate_at, in_axes=(None, None, 0))(state, key, prefs)

    return np.asarray(program(jax.random.key(0), jnp.asarray(BANDIT_PREFS))["eval/return"])


def test_one_network_recovers_the_concave_front_between_the_ends(bandit_front):
    """The non-convex part, which linear weighting cannot reach: every interior
    preference lands on the exact front, away from both ends, near its weighted-Chebyshev
    optimum, in the preferences' order."""
    front = concave_bandit.exact_front(2001)
    theta = np.arctan2(1.0 - bandit_front[:, 0], 1.0 - bandit_front[:, 1])
    for point, angle, pref in zip(bandit_front, theta, BANDIT_PREFS, strict=True):
        assert np.min(np.linalg.norm(front - point, axis=1)) < 0.01
        assert 0.2 < angle < np.pi / 2 - 0.2
        assert angle == pytest.approx(float(concave_bandit.wc_optimum(pref)), abs=0.15)
    assert np.all(np.diff(theta) > 0.1)


def test_cli_trains_one_network_and_evaluates_it_at_every_preference(tmp_path, capsys):
    """`python -m wcac_jax.sweep --conditioned --total-steps 40000 --eval-prefs 5` on
    Walker2d (its defaults: the v5 model on MuJoCo's C engine): one network, its front at
    five evenly spread preferences, the training's env steps alone in `env_steps_total`,
    a policy at any preference from `load_sweep`, and `--resume` of the finished run."""
    out = str(tmp_path / "run")
    args = ["--conditioned", "--total-steps", "40000", "--eval-prefs", "5", "--out", out]
    assert cli.main([*args, "--quiet"]) == 0
    with open(os.path.join(out, "front.json")) as f:
        front = json.load(f)
    assert [r["pref"] for r in front["prefs"]] == pareto.simplex_lattice(2, 5).tolist()
    per_iteration = conditioned.ConditionedConfig().env_steps_per_iteration
    assert 40_000 <= front["env_steps_total"] < 40_000 + per_iteration
    assert front["conditioned"]["networks"] == 1 and front["conditioned"]["eval_prefs"] == 5
    assert front["conditioned"]["preferences"] == "drawn per episode"
    # the evaluation's steps: 8 episodes per preference, each row's mean length times 8
    steps = 8 * sum(r["episode_length"] for r in front["prefs"])
    assert front["conditioned"]["eval_env_steps"] == round(steps) <= 5 * 8 * 500
    assert front["config"]["train"]["kind"] == "conditioned"
    for name in ("front.png", "front.csv", "curves.npz", "config.json"):
        assert os.path.isfile(os.path.join(out, name))
    run = sweep.load_sweep(out)
    obs = np.zeros((3, int(run.env.observation_size)), np.float32)
    ends = [np.asarray(run.policy_at(p)(obs)) for p in ([1.0, 0.0], [0.0, 1.0])]
    assert ends[0].shape == (3, int(run.env.action_size))
    assert not np.allclose(ends[0], ends[1])  # the preference is an input
    assert cli.main([*args, "--quiet", "--resume"]) == 0  # finished: nothing to do
    with open(os.path.join(out, "front.json")) as f:
        assert json.load(f) == front
    # a finished run is not written over without --overwrite: one line, exit 2, same bytes
    before = {
        n: open(os.path.join(out, n), "rb").read()
        for n in sorted(os.listdir(out))
        if os.path.isfile(os.path.join(out, n))
    }
    assert cli.main([*args, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not empty" in err and out in err
    after = {
        n: open(os.path.join(out, n), "rb").read()
        for n in sorted(os.listdir(out))
        if os.path.isfile(os.path.join(out, n))
    }
    assert after == before


def _experiment():
    import importlib.util
    import sys

    sys.path.insert(0, os.path.join(ROOT, "experiments"))  # the scripts beside it
    path = os.path.join(ROOT, "experiments", "conditioned_front.py")
    found = importlib.util.spec_from_file_location("conditioned_front", path)
    module = importlib.util.module_from_spec(found)
    found.loader.exec_module(module)
    return module


ROOT = os.path.join(os.path.dirname(__file__), os.pardir)


def test_front_metrics_by_hand():
    """A made-up front of three preferences (8 episodes each, time limit 500): every
    number of a summary row by hand. `[1, 0]` lasts 250 steps on average, so at most 3 of
    its 8 episodes lasted 500 (4 x 500 + 4 x 1 > 8 x 250): 5 to 8 falls, 0.625 to 1 per
    episode, its speed `(R0 - L + f) / L` between (1000 - 250 + 0.625) / 250 and
    (1000 - 250 + 1) / 250, the middle reported."""
    exp = _experiment()
    rows = [([1.0, 0.0], [1000.0, -300.0], 250.0), ([0.5, 0.5], [600.0, 200.0], 500.0)]
    rows.append(([0.0, 1.0], [500.0, 480.0], 500.0))
    discounted = [[300.0, -150.0], [200.0, 100.0], [150.0, 200.0]]
    front = {
        "prefs": [
            {"pref": p, "return": r, "discounted_return": d, "episode_length": n}
            | {"nondominated": True}
            for (p, r, n), d in zip(rows, discounted, strict=True)
        ],
        "hypervolume": 1.0,
        "expected_utility": 2.0,
        "env_steps_total": 300,
        "wall_s": 3.0,
        "train_s": 2.0,
        "compile_s": 1.0,
        "config": {"env": "walker2d", "env_options": {}, "eval_episodes": 8},
    }
    m = exp.front_metrics(front)
    # morl-baselines: the discounted points from (-100, -100); (300, -150) lies below the
    # reference on the second objective and adds nothing; (200, 100) and (150, 200) make
    # a staircase: 300 x 200 + 250 x 100
    assert m["hv_morl_baselines"] == pytest.approx(300 * 200 + 250 * 100)
    assert m["nondominated"] == 3 and m["n_prefs"] == 3
    assert m["spearman_p0_forward"] == pytest.approx(1.0)
    assert m["forward_end_speed"] == pytest.approx((1000 - 250 + 0.8125) / 250)
    assert m["forward_end_length"] == 250.0 and m["control_end_control_return"] == 480.0
    assert (m["hv_project"], m["expected_utility"], m["wall_s"]) == (1.0, 2.0, 3.0)


@pytest.mark.parametrize(
    ("flags", "expected"),
    [
        ([], "--out {out!r} is not empty (--resume adds to it, --overwrite replaces it)"),
        (
            ["--resume", "--overwrite"],
            "--out {out!r}: --resume adds to it and --overwrite replaces it: give one",
        ),
        (
            ["--summarize-only", "--overwrite"],
            "--out {out!r}: --summarize-only reads it and --overwrite replaces it",
        ),
    ],
)
def test_experiment_refuses_a_non_empty_out(tmp_path, capsys, flags, expected):
    """Refused before any training: exit 2, one line naming --out, every file unchanged."""
    exp = _experiment()
    out = tmp_path / "out"
    (out / "conditioned" / "seed0").mkdir(parents=True)
    (out / "conditioned" / "seed0" / "front.json").write_text("{}")
    (out / "summary.json").write_text("mine")
    before = {str(p): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    with pytest.raises(SystemExit) as exc:
        exp.main([*flags, "--out", str(out), "--work", str(tmp_path / "work")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.splitlines() == ["error: " + expected.format(out=str(out))]
    assert {str(p): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert not (tmp_path / "work").exists()


def test_experiment_resume_keeps_the_recorded_runs(tmp_path, monkeypatch):
    """--resume on a non-empty --out reads a run it records (no training) and writes the
    summary beside it, leaving the run's files as they were."""
    exp = _experiment()
    committed = os.path.join(ROOT, "experiments", "results", "conditioned_walker2d")
    out, work = tmp_path / "out", tmp_path / "work"
    (out / "conditioned" / "seed0").mkdir(parents=True)
    (work / "conditioned" / "seed0").mkdir(parents=True)
    front = open(os.path.join(committed, "conditioned", "seed0", "front.json"), "rb").read()
    (out / "conditioned" / "seed0" / "front.json").write_bytes(front)
    (out / "conditioned" / "seed0" / "machine.json").write_text('{"process_s": 1.0}')
    (work / "conditioned" / "seed0" / "front.json").write_bytes(front)
    before = {str(p): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    monkeypatch.setattr("wcac_jax.sweep.cli.main", lambda *a: pytest.fail("trained"))
    exp.main(
        ["--resume", "--out", str(out), "--work", str(work), "--seeds", "0"]
        + ["--arms", "conditioned", "--cost-prefs", "--reuse-9x1m", str(tmp_path / "none")]
    )
    after = {str(p): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert {k: after[k] for k in before} == before
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"].keys() == {"conditioned"}
    assert summary["runs"]["conditioned"].keys() == {"0"}
    assert (out / "front.json").read_bytes() == front
