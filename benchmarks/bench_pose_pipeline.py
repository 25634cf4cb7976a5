"""Pose pipeline throughput at 640x480 on one core: detection + sub-pixel corners + pose.

Renders a set of frames (2 bricks each, camera 1.2 m above them) once, then times, per frame:

- ``estimate_bricks`` (detect, edge-line corner refinement, joint 8-corner fit per brick): the pipeline;
- ``detect_tags`` (same detection, one IPPE_SQUARE pose per marker);
- OpenCV's ``ArucoDetector.detectMarkers`` alone, for scale;
- ``render_frame`` (the simulator's camera).

OpenCV runs single-threaded (``cv2.setNumThreads(1)``) and times are process CPU seconds, so other load on a
shared machine does not inflate them. Target: >= 100 frames/s for the pipeline.

    .venv/bin/python benchmarks/bench_pose_pipeline.py
    .venv/bin/python benchmarks/bench_pose_pipeline.py --frames 100 --bricks 4
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable

import cv2
import numpy as np

from masonry.blueprint import MarkerSpec
from masonry.perception.aruco import _detector, detect_tags, estimate_bricks
from masonry.perception.render import random_view, render_frame
from masonry.perception.types import CameraIntrinsics


def per_call_s(fn: Callable[[], object], repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--bricks", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3, help="best of N passes over the frames")
    args = ap.parse_args()

    cv2.setNumThreads(1)
    intr = CameraIntrinsics(600.0, 600.0, 319.5, 239.5)
    markers = MarkerSpec()
    rng = np.random.default_rng(0)
    scenes = [random_view(rng, intr, markers, n_bricks=args.bricks) for _ in range(args.frames)]
    images = [render_frame(intr, T, b, markers, rng=rng, blur_sigma_px=0.8) for T, b in scenes]
    detector = _detector(markers.dictionary)
    n = len(images)

    def over_frames(f: Callable[[np.ndarray], object]) -> Callable[[], None]:
        return lambda: [f(im) for im in images] and None

    rows = [
        ("estimate_bricks (detect + joint pose)", over_frames(lambda im: estimate_bricks(im, intr, markers))),
        ("detect_tags (detect + per-marker pose)", over_frames(lambda im: detect_tags(im, intr, markers))),
        ("ArucoDetector.detectMarkers only", over_frames(detector.detectMarkers)),
        ("render_frame", lambda: [render_frame(intr, T, b, markers, rng=rng) for T, b in scenes] and None),
    ]
    found = sum(len(estimate_bricks(im, intr, markers)) for im in images)
    print(
        f"# {platform.python_version()} opencv {cv2.__version__} {platform.machine()}, one thread, CPU time"
    )
    print(f"# {n} frames 640x480, {args.bricks} bricks each ({found} of {n * args.bricks} bricks found)")
    for name, fn in rows:
        s = per_call_s(fn, args.repeats) / n
        print(f"{name:42s} {s * 1e3:7.2f} ms/frame  {1.0 / s:8.0f} frames/s")


if __name__ == "__main__":
    main()
