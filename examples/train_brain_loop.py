"""Learn homing when path integration is part of the problem: the CX's home vector against the oracle's.

Three conditions of ``neuronav/AntHoming-v0`` (kinematic backend by default; the brains in the loop:
:mod:`neuronav.scenarios.envs.brain_loop`):

- ``oracle``: the observation ``home_vector`` is the true vector (a perfect path integrator);
- ``cx``: ``home_vector="cx"``, the central complex's own estimate, decoded from its CPU4 memory after
  it integrated the foraging walk (with the scenario's compass, odometer and rate noise): the policy
  must home on what the insect's path integrator knows;
- ``cx_residual``: ``home_vector="cx"`` with the CX's populations (TB1, CPU4, CPU1) in the observation
  and the action added to the CX's own steering (residual control): the policy starts from the insect's
  competence and may only improve on it.

Each is trained the same way (``--algo``): stable-baselines3's PPO (``MultiInputPolicy``, ``ppo``), or the
numpy cross-entropy method of ``train_homing.py`` (a linear policy of the home vector's direction,
``cem``); the default ``auto`` takes PPO when stable-baselines3 is installed. After every iteration (a
CEM generation of 16 policies x 2 episodes; a PPO rollout of 1024 steps; 12 of them) the current policy
(the CEM's mean, PPO's deterministic policy) is evaluated on 8 fixed episodes: the curve is its mean
return (m of progress toward the nest) and its success rate (the fraction that reached the nest) per
iteration, for each condition.

Run (writes ``learning_curves.csv``, ``learning_curves.json`` and ``learning_curves.png`` into ``--out``)::

    python examples/train_brain_loop.py --out runs/train_brain_loop
    python examples/train_brain_loop.py --quick --out /tmp/brain_loop     # a few seconds (CI)
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import sys
import time
from pathlib import Path

import numpy as np

from neuronav.scenarios.envs.brain_loop import brain_homing_env

HERE = Path(__file__).resolve().parent
CONDITIONS = ("oracle", "cx", "cx_residual")
# Shorter trips than the scenario's (32 s out, 90 s home), as in train_homing.py: 19.2 s = 30 gait cycles home.
FULL_SETTINGS = {"outbound_s": 16.0, "homing_timeout_s": 19.2}
# --quick: 15 gait cycles out, 3 home.
QUICK_SETTINGS = {"outbound_s": 9.6, "homing_timeout_s": 1.92}
FULL = {"iterations": 12, "population": 16, "elite": 4, "episodes": 2, "eval_episodes": 8, "n_steps": 1024}
QUICK = {"iterations": 2, "population": 3, "elite": 1, "episodes": 1, "eval_episodes": 1, "n_steps": 32}


def load_train_homing():
    """``examples/train_homing.py`` as a module (its CEM, its linear policy, its episode loop)."""
    spec = importlib.util.spec_from_file_location("train_homing", HERE / "train_homing.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def make_condition(condition: str, backend: str = "kinematic", settings: dict | None = None):
    """The environment of ``condition`` (one of :data:`CONDITIONS`)."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {', '.join(CONDITIONS)}; got {condition!r}")
    residual = condition == "cx_residual"
    return brain_homing_env("oracle" if condition == "oracle" else "cx", populations=residual, residual=residual,
                            backend=backend, **(settings or FULL_SETTINGS))


def sb3_available() -> bool:
    return importlib.util.find_spec("stable_baselines3") is not None


def train_cem_curve(condition: str, sizes: dict, seed: int, backend: str, settings: dict) -> list[dict]:
    """The CEM's curve on ``condition``: per generation (``episodes``: training episodes before it), the mean
    policy's evaluation return and success."""
    train_homing = load_train_homing()
    _, curve = train_homing.train_cem(sizes["iterations"], sizes["population"], sizes["elite"], sizes["episodes"],
                                      sizes["eval_episodes"], seed,
                                      make=lambda: make_condition(condition, backend, settings))
    return [{"condition": condition, "algo": "cem", "iteration": row["generation"], "episodes": row["episodes"],
             "return_m": row["policy_return"], "success": row["policy_success"]} for row in curve]


def train_ppo_curve(condition: str, sizes: dict, seed: int, backend: str, settings: dict) -> list[dict]:
    """PPO's curve on ``condition``: after every rollout of ``n_steps`` (``steps``: gait cycles trained on),
    the deterministic policy's evaluation return and success on the fixed evaluation seeds."""
    from stable_baselines3 import PPO

    train_homing = load_train_homing()
    env = make_condition(condition, backend, settings)
    evaluation = make_condition(condition, backend, settings)
    n_steps = sizes["n_steps"]
    model = PPO("MultiInputPolicy", env, n_steps=n_steps, batch_size=min(64, n_steps), seed=seed, verbose=0)
    policy = lambda observation: model.predict(observation, deterministic=True)[0]  # noqa: E731
    eval_seeds = [10_000 + k for k in range(sizes["eval_episodes"])]
    curve = []
    for iteration in range(sizes["iterations"] + 1):
        if iteration:
            model.learn(total_timesteps=n_steps, reset_num_timesteps=False)
        results = np.array([train_homing.episode_return(evaluation, policy, s) for s in eval_seeds], dtype=float)
        curve.append({"condition": condition, "algo": "ppo", "iteration": iteration,
                      "steps": int(model.num_timesteps), "return_m": float(results[:, 0].mean()),
                      "success": float(results[:, 1].mean())})
    env.close()
    evaluation.close()
    return curve


def train_all(algo: str = "auto", quick: bool = False, seed: int = 0, backend: str = "kinematic",
              conditions=CONDITIONS) -> tuple[list[dict], dict]:
    """Train every condition; returns the curve rows and the run's facts (algo, sizes, settings, CPU s)."""
    if algo == "auto":
        algo = "ppo" if sb3_available() else "cem"
    if algo == "ppo" and not sb3_available():
        raise SystemExit("--algo ppo needs stable-baselines3: pip install 'neuronav[rl]' (or --algo cem)")
    sizes, settings = (QUICK, QUICK_SETTINGS) if quick else (FULL, FULL_SETTINGS)
    train = train_ppo_curve if algo == "ppo" else train_cem_curve
    rows, cpu_s = [], {}
    for condition in conditions:
        started = time.process_time()
        rows += train(condition, sizes, seed, backend, settings)
        cpu_s[condition] = round(time.process_time() - started, 1)
    facts = {"algo": algo, "quick": quick, "seed": seed, "backend": backend, "sizes": sizes, "settings": settings,
             "cpu_s": cpu_s, "x": "training episodes" if algo == "cem" else "training steps (gait cycles)"}
    return rows, facts


def curves_figure(rows: list[dict], facts: dict):
    """Two panels: the evaluation return and the success rate per iteration, one line per condition."""
    import matplotlib.pyplot as plt

    figure, (returns, success) = plt.subplots(1, 2, figsize=(10, 4))
    trained = "episodes" if facts["algo"] == "cem" else "steps"
    for condition in dict.fromkeys(row["condition"] for row in rows):
        mine = [row for row in rows if row["condition"] == condition]
        x = [row[trained] for row in mine]
        returns.plot(x, [row["return_m"] for row in mine], "o-", label=condition)
        success.plot(x, [row["success"] for row in mine], "o-", label=condition)
    n = facts["sizes"]["eval_episodes"]
    returns.set_ylabel(f"evaluation return (m toward the nest), mean of {n}")
    success.set_ylabel(f"success rate ({n} evaluation episodes)")
    success.set_ylim(-0.05, 1.05)
    for axes in (returns, success):
        axes.set_xlabel(facts["x"])
        axes.legend()
    figure.suptitle(f"AntHoming-v0 ({facts['backend']}), {facts['algo']}: home_vector oracle vs cx vs cx + residual")
    figure.tight_layout()
    return figure


def write_curves(rows: list[dict], facts: dict, out_dir: Path) -> list[Path]:
    """``learning_curves.csv``, ``learning_curves.json`` (rows and facts) and ``learning_curves.png``."""
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    table = out_dir / "learning_curves.csv"
    with table.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    record = out_dir / "learning_curves.json"
    record.write_text(json.dumps({"facts": facts, "curve": rows}, indent=1))
    figure = curves_figure(rows, facts)
    image = out_dir / "learning_curves.png"
    figure.savefig(image, dpi=120)
    plt.close(figure)
    return [table, record, image]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", choices=("auto", "cem", "ppo"), default="auto",
                        help="auto: ppo when stable-baselines3 is installed, else cem")
    parser.add_argument("--quick", action="store_true", help="a few seconds: 2 iterations, 3-cycle episodes (CI)")
    parser.add_argument("--backend", default="kinematic")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--conditions", default=",".join(CONDITIONS), help="comma list of " + ", ".join(CONDITIONS))
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    args = parser.parse_args(argv)
    conditions = tuple(c.strip() for c in args.conditions.split(","))
    unknown = [c for c in conditions if c not in CONDITIONS]
    if unknown:
        parser.error(f"unknown condition {', '.join(unknown)}; allowed: {', '.join(CONDITIONS)}")
    rows, facts = train_all(args.algo, args.quick, args.seed, args.backend, conditions)
    for condition in conditions:
        mine = [row for row in rows if row["condition"] == condition]
        print(f"{condition:12s} " + "  ".join(f"{row['iteration']}: {row['return_m']:.2f} m {row['success']:.2f}"
                                              for row in mine) + f"  ({facts['cpu_s'][condition]} CPU s)")
    for path in write_curves(rows, facts, args.out):
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
