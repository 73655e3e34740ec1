"""Benchmark: one step of the compiled mushroom body (4000 KCs, 81 inputs) against a hand-written numpy one.

Measures, on one core (BLAS limited to one thread):

(a) batch 1: ``CompiledCircuit.step`` of ``neuronav.brains.mushroom_body.mushroom_body()`` (learning off)
    against :class:`MushroomBodyNumpy` (a dense BLAS product for PN→KC, the threshold, each
    agent's KC→MBON weights); target compiled/hand-written <= 1.0;
(b) batch N (default 1000): cost per agent-step of both, and the compiled circuit's per-agent
    speed-up batch 1 -> batch N (the issue's target: >= 20x), in float64 and float32;
(c) learning a 1000-view route: 1000 steps with learning on, one agent, both versions;
(d) the ceiling on (b): the compiled batch-1 step divided by the per-agent time of the bare PN→KC
    product alone at batch N, the faster of a dense BLAS call and scipy's sparse product (each KC
    reads 10 PNs), nothing else. A step that computes every KC's input costs at least that, so
    batching cannot beat this speed-up on this CPU.

Inputs are z-scored random codes (about 3 % of the KCs active at the default threshold, as on
forest views). Each repeat times ``--steps`` steps after one untimed step; ratios use the best of
``--repeats`` repeats.

Usage::

    python benchmarks/mushroom_body.py [--steps 400] [--repeats 5] [--batch 1000]
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without installing

from neuronav.brains.mushroom_body import KC_THRESHOLD, kc_wiring, mushroom_body, pn_code  # noqa: E402

N_PN, N_KC, INPUTS_PER_KC = 81, 4000, 10
TARGET_BATCH1_RATIO = 1.0
TARGET_PER_AGENT_SPEEDUP = 20.0


class MushroomBodyNumpy:
    """The same model written by hand: KC = [W x > τ] (one BLAS product), MBON = Σ w KC per agent,
    learning: the active KCs' weights minus the rate, floored at 0, for agents whose gate is on."""

    def __init__(self, batch: int, dtype=np.float64, seed: int = 0, rate: float = 1.0) -> None:
        self.w_pn_kc = kc_wiring(N_KC, N_PN, INPUTS_PER_KC, seed).T.astype(dtype)  # (PN, KC)
        self.w_kc_mbon = np.ones((batch, N_KC), dtype)
        self.rate = rate

    def step(self, pn: np.ndarray, learning: np.ndarray) -> np.ndarray:
        kc = pn @ self.w_pn_kc > KC_THRESHOLD  # (batch, KC)
        novelty = np.einsum("bk,bk->b", self.w_kc_mbon, kc)
        on = learning[:, 0] > 0.5
        if on.any():
            self.w_kc_mbon[on] = np.maximum(self.w_kc_mbon[on] - self.rate * kc[on], 0.0)
        return novelty[:, None]


def best_time(step, inputs: list, repeats: int) -> float:
    """Best seconds per step over ``repeats`` loops through ``inputs`` (one untimed step first)."""
    step(*inputs[0])
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for arguments in inputs:
            step(*arguments)
        times.append((time.perf_counter() - start) / len(inputs))
    return min(times)


def codes(batch: int, steps: int, dtype, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [pn_code(rng.normal(size=(batch, N_PN))).astype(dtype) for _ in range(steps)]


def step_times(batch: int, steps: int, repeats: int, dtype) -> tuple[float, float]:
    """(compiled, hand-written) seconds per step at ``batch``, learning off."""
    sim = mushroom_body().compile(batch=batch, dtype=dtype, check_inputs=False)
    reference = MushroomBodyNumpy(batch, dtype)
    off = np.zeros((batch, 1), dtype)
    views = codes(batch, steps, dtype)
    compiled = best_time(lambda pn, gate: sim.step({"pn": pn, "learning": gate}), [(v, off) for v in views], repeats)
    numpy_time = best_time(reference.step, [(v, off) for v in views], repeats)
    return compiled, numpy_time


def bare_product_time(batch: int, steps: int, repeats: int, dtype) -> tuple[float, str]:
    """Seconds of the PN→KC product alone at ``batch`` (the faster of dense BLAS and a scipy sparse
    product, if scipy is installed) and which it was: the floor of any mushroom-body step."""
    w_kc_pn = kc_wiring(N_KC, N_PN, INPUTS_PER_KC, 0).astype(dtype)
    views = [(v,) for v in codes(batch, steps, dtype)]
    dense = np.ascontiguousarray(w_kc_pn.T)
    times = {"dense BLAS": best_time(lambda pn: pn @ dense, views, repeats)}
    try:
        from scipy import sparse
    except ImportError:
        return times["dense BLAS"], "dense BLAS"
    w_sparse = sparse.csr_matrix(w_kc_pn)
    times["scipy sparse"] = best_time(lambda pn: w_sparse @ np.ascontiguousarray(pn.T), views, repeats)
    fastest = min(times, key=times.get)
    return times[fastest], fastest


def route_learning_times(views: int = 1000) -> tuple[float, float]:
    """(compiled, hand-written) seconds to learn a route of ``views`` views, one agent."""
    route = codes(1, views, np.float64, seed=1)
    on = np.ones((1, 1))
    sim = mushroom_body().compile(batch=1, check_inputs=False)
    start = time.perf_counter()
    for view in route:
        sim.step({"pn": view, "learning": on})
    compiled = time.perf_counter() - start
    reference = MushroomBodyNumpy(1)
    start = time.perf_counter()
    for view in route:
        reference.step(view, on)
    numpy_time = time.perf_counter() - start
    same = np.array_equal(sim.weights("KC->MBON")[0, 0], reference.w_kc_mbon[0])
    print(f"  both learnt the same weights: {same}; KC weights at 0: "
          f"{100 * np.mean(reference.w_kc_mbon == 0):.1f} %")
    return compiled, numpy_time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--batch", type=int, default=1000)
    args = parser.parse_args()
    print(f"mushroom body: {N_PN} PNs, {N_KC} KCs ({INPUTS_PER_KC} inputs each), 1 MBON; python "
          f"{platform.python_version()}, numpy {np.__version__}, {platform.machine()}")
    for dtype in (np.float64, np.float32):
        name = np.dtype(dtype).name
        one, one_numpy = step_times(1, args.steps, args.repeats, dtype)
        many, many_numpy = step_times(args.batch, max(4, args.steps // 100), args.repeats, dtype)
        print(f"[{name}] batch 1: compiled {one * 1e6:.1f} us/step, hand-written {one_numpy * 1e6:.1f} us/step, "
              f"ratio {one / one_numpy:.2f} (target <= {TARGET_BATCH1_RATIO})")
        print(f"[{name}] batch {args.batch}: compiled {many * 1e3:.2f} ms/step = {many / args.batch * 1e6:.2f} "
              f"us/agent-step, hand-written {many_numpy / args.batch * 1e6:.2f} us/agent-step; per-agent "
              f"speed-up of the compiled circuit batch 1 -> {args.batch}: {one / (many / args.batch):.1f}x "
              f"(target >= {TARGET_PER_AGENT_SPEEDUP:g}x)")
        floor, how = bare_product_time(args.batch, max(4, args.steps // 100), args.repeats, dtype)
        floor /= args.batch
        print(f"[{name}] ceiling: the bare PN->KC product alone ({how}) costs {floor * 1e6:.2f} us/agent at "
              f"batch {args.batch} (the compiled step: {many / args.batch / floor:.2f}x that), so batching cannot "
              f"beat batch 1 -> {args.batch} by more than {one / floor:.1f}x here")
    print("learning a 1000-view route (one agent, learning on every step):")
    compiled, numpy_time = route_learning_times()
    print(f"  compiled {compiled * 1e3:.1f} ms, hand-written {numpy_time * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
