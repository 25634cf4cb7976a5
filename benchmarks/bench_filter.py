"""Marker filter: exact `refine_markers` against the paper's scipy BFGS (numerical gradients). Prints the figures.

Inputs are realistic two-marker detections: a brick 1.2 m below the camera, random yaw, detection noise of 3 mm
across and 15 mm along the optical axis (depth is what a single 5 cm marker gets worst). Both solvers see the same
inputs; the script reports the time per call, the speed ratio, and the cost J each reaches.

    python benchmarks/bench_filter.py [--samples 500] [--seed 0] [--rounds 7]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from masonry.perception import (
    EstimatorConfig,
    TagPose,
    estimate_brick_pose,
    marker_cost,
    refine_markers,
    refine_markers_bfgs,
)


def make_inputs(samples: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(samples):
        yaw = rng.uniform(-math.pi, math.pi)
        axis = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        center = np.array([rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), 1.2])
        noise = rng.normal(0.0, [0.003, 0.003, 0.015], size=(2, 3))
        out.append((center + axis * 0.0875 + noise[0], center - axis * 0.0875 + noise[1]))
    return out


def per_call_us(fn, inputs, loops: int = 1) -> float:
    """Mean time per call (microseconds) over ``loops`` passes through ``inputs``."""
    t0 = time.perf_counter()
    for _ in range(loops):
        for p1, p2 in inputs:
            fn(p1, p2)
    return (time.perf_counter() - t0) / (loops * len(inputs)) * 1e6


def interleaved_best_us(fast, slow, inputs, rounds: int) -> tuple[float, float]:
    """Best (minimum) per-call time of each solver over ``rounds`` alternating passes on the same inputs.

    Alternating the two solvers exposes both to the same machine load (the CI box is shared); the minimum is the
    usual estimator of the undisturbed cost.
    """
    batch = inputs[: min(len(inputs), 100)]
    best_fast, best_slow = math.inf, math.inf
    for _ in range(rounds):
        best_fast = min(best_fast, per_call_us(fast, batch, loops=20))
        best_slow = min(best_slow, per_call_us(slow, batch))
    return best_fast, best_slow


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rounds", type=int, default=7, help="alternating timing rounds (best is reported)")
    args = parser.parse_args()
    cfg = EstimatorConfig()
    weights = (cfg.spacing_m, cfg.w_prox, cfg.w_dist, cfg.w_plane, cfg.up)
    inputs = make_inputs(args.samples, args.seed)

    def exact(p1, p2):
        return refine_markers(p1, p2, *weights)

    def bfgs(p1, p2):
        return refine_markers_bfgs(p1, p2, *weights)

    def bfgs_raw(p1, p2):
        return refine_markers_bfgs(p1, p2, *weights, fallback=False)

    exact(*inputs[0])
    bfgs(*inputs[0])
    t_exact, t_bfgs = interleaved_best_us(exact, bfgs, inputs, rounds=args.rounds)

    gaps, fallbacks, strictly_better = [], 0, 0
    for p1, p2 in inputs:
        j_exact = marker_cost(*exact(p1, p2), p1, p2, *weights)
        j_bfgs = marker_cost(*bfgs_raw(p1, p2), p1, p2, *weights)
        j_paper = marker_cost(*bfgs(p1, p2), p1, p2, *weights)
        gaps.append(j_exact - j_bfgs)
        fallbacks += j_paper != j_bfgs
        strictly_better += j_exact < j_bfgs - 1e-12

    tags = []
    for p1, p2 in inputs:
        d = p1 - p2
        R = np.eye(3)
        R[:, 0] = d / np.linalg.norm(d)
        tags.append((TagPose(6, p1, R), TagPose(7, p2, R)))
    t0 = time.perf_counter()
    for t1, t2 in tags:
        estimate_brick_pose(t1, t2, cfg)
    t_pose_two = (time.perf_counter() - t0) / len(tags) * 1e6
    t0 = time.perf_counter()
    for t1, _ in tags:
        estimate_brick_pose(t1, None, cfg)
    t_pose_one = (time.perf_counter() - t0) / len(tags) * 1e6

    print(f"samples                          {len(inputs)}")
    print(f"refine_markers (exact)           {t_exact:8.2f} us/call (best of {args.rounds} rounds)")
    print(f"scipy BFGS, numerical gradients  {t_bfgs:8.1f} us/call")
    print(f"speed ratio                      {t_bfgs / t_exact:8.0f} x   (target >= 100 x)")
    print(
        f"J(exact) - J(BFGS): max          {max(gaps):+.3e}   mean {statistics.fmean(gaps):+.3e}   min {min(gaps):+.3e}"
    )
    print(f"exact strictly lower J           {strictly_better} / {len(inputs)}")
    print(f"BFGS reported failure (fallback) {fallbacks} / {len(inputs)}")
    print(f"estimate_brick_pose, two tags    {t_pose_two:8.2f} us/call")
    print(f"estimate_brick_pose, one tag     {t_pose_one:8.2f} us/call")


if __name__ == "__main__":
    main()
