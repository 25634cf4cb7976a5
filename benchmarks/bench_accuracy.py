"""Brick pose accuracy on rendered frames against the truth.

Random views (default 250 frames, 2 bricks each): camera 1.2 m above the brick tops, up to 5 degrees of tilt,
random heading; Gaussian blur sigma uniform in 0.5-1.0 px, sensor noise sigma 2 grey levels; 640x480, f = 600 px;
DICT_4X4_50, 5 cm markers 17.5 cm apart. For each method it prints the 2-D (world x-y) error of the top-face
centre, the 3-D error and the yaw error (about the optical axis):

- joint:      ``estimate_bricks`` (edge-line corners, one fit to all 8 corners of the brick's markers);
- joint, one marker hidden (a random one of each brick's two is not drawn): 4 corners + the known offset;
- paper:      ``detect_tags`` per-marker IPPE_SQUARE poses + ``estimate_brick_pose`` (the paper's filter);
- opencv:     plain OpenCV: ArucoDetector with CORNER_REFINE_SUBPIX, per-marker IPPE_SQUARE, midpoint.

Targets (issue): mean 2-D <= 0.5 cm and yaw <= 0.5 deg; one marker hidden <= 1.5 cm mean, 3 cm worst.

    .venv/bin/python benchmarks/bench_accuracy.py
    .venv/bin/python benchmarks/bench_accuracy.py --frames 400 --blur 0.8 1.2 --height 1.8
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

import cv2
import numpy as np

from masonry.blueprint import MarkerSpec
from masonry.perception.aruco import aruco_dictionary, detect_tags, estimate_bricks, yaw_about_rad
from masonry.perception.estimation import EstimatorConfig, estimate_brick_pose
from masonry.perception.render import RenderedBrick, random_view, render_frame
from masonry.perception.types import CameraIntrinsics

INTR = CameraIntrinsics(600.0, 600.0, 319.5, 239.5)
MARKERS = MarkerSpec()

# A method maps an image to {brick id: (centre in the camera frame, yaw about the optical axis)}.
Method = Callable[[np.ndarray], dict[int, tuple[np.ndarray, float]]]


def joint(image: np.ndarray) -> dict[int, tuple[np.ndarray, float]]:
    return {e.brick_id: (e.center_m, e.yaw_rad) for e in estimate_bricks(image, INTR, MARKERS)}


def paper(image: np.ndarray) -> dict[int, tuple[np.ndarray, float]]:
    cfg = EstimatorConfig(spacing_m=MARKERS.spacing_m)
    tags = {t.marker_id: t for t in detect_tags(image, INTR, MARKERS)}
    out = {}
    for k in {i // 2 for i in tags}:
        est = estimate_brick_pose(tags.get(2 * k), tags.get(2 * k + 1), cfg)
        if est is not None:
            out[k] = (est.center_m, est.yaw_rad)
    return out


def opencv_plain(image: np.ndarray) -> dict[int, tuple[np.ndarray, float]]:
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(aruco_dictionary(MARKERS.dictionary), params)
    corners, ids, _ = detector.detectMarkers(image)
    h = MARKERS.size_m / 2.0
    obj = np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])
    centres: dict[int, np.ndarray] = {}
    for c, i in zip(corners, [] if ids is None else ids.ravel()):
        ok, _rvec, tvec = cv2.solvePnP(
            obj, c.reshape(4, 2), INTR.matrix(), INTR.dist_coeffs(), flags=cv2.SOLVEPNP_IPPE_SQUARE
        )
        if ok:
            centres[int(i)] = tvec.ravel()
    out = {}
    for k in {i // 2 for i in centres}:
        if 2 * k in centres and 2 * k + 1 in centres:
            a, b = centres[2 * k], centres[2 * k + 1]
            out[k] = ((a + b) / 2.0, yaw_about_rad(a - b))
    return out


def truth(T: np.ndarray, b: RenderedBrick) -> tuple[np.ndarray, float]:
    top = np.asarray(b.position_m) + np.array([0.0, 0.0, b.size_m[2] / 2.0])
    x_cam = T[:3, :3].T @ np.array([math.cos(b.yaw_rad), math.sin(b.yaw_rad), 0.0])
    return top, yaw_about_rad(x_cam)


def run(
    method: Method, frames: int, seed: int, hide_one: bool, blur: tuple[float, float], height: float
) -> None:
    rng = np.random.default_rng(seed)
    e2, e3, ey, missed, total = [], [], [], 0, 0
    for _ in range(frames):
        T, bricks = random_view(rng, INTR, MARKERS, n_bricks=2, height_m=height)
        hidden = (
            frozenset(2 * b.brick_id + int(rng.integers(0, 2)) for b in bricks) if hide_one else frozenset()
        )
        image = render_frame(
            INTR,
            T,
            bricks,
            MARKERS,
            rng=rng,
            blur_sigma_px=float(rng.uniform(*blur)),
            noise_sigma=2.0,
            hidden_markers=hidden,
        )
        found = method(image)
        for b in bricks:
            total += 1
            if b.brick_id not in found:
                missed += 1
                continue
            centre_c, yaw = found[b.brick_id]
            centre_w = T[:3, :3] @ centre_c + T[:3, 3]
            top_w, yaw_true = truth(T, b)
            e2.append(float(np.hypot(*(centre_w - top_w)[:2])))
            e3.append(float(np.linalg.norm(centre_w - top_w)))
            ey.append(abs(math.remainder(yaw - yaw_true, math.tau)))
    a2, a3, ay = np.array(e2) * 100.0, np.array(e3) * 100.0, np.degrees(ey)
    print(
        f"  2-D centre cm: mean {a2.mean():.3f}  p95 {np.percentile(a2, 95):.3f}  max {a2.max():.3f} | "
        f"3-D cm: mean {a3.mean():.3f}  max {a3.max():.3f} | yaw deg: mean {ay.mean():.3f}  max {ay.max():.3f} | "
        f"found {total - missed}/{total}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=250)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--blur", type=float, nargs=2, default=(0.5, 1.0), metavar=("MIN", "MAX"))
    ap.add_argument("--height", type=float, default=1.2, help="camera height above the brick tops, m")
    args = ap.parse_args()
    blur = (args.blur[0], args.blur[1])
    print(
        f"# {args.frames} frames x 2 bricks, camera {args.height} m above the tops, tilt <= 5 deg, "
        f"blur {blur[0]}-{blur[1]} px, noise 2 grey levels, 640x480 f=600 px"
    )
    for name, method, hide in (
        ("joint fit (estimate_bricks), both markers", joint, False),
        ("joint fit (estimate_bricks), one marker hidden", joint, True),
        ("paper: per-marker IPPE_SQUARE + estimate_brick_pose, both markers", paper, False),
        ("paper: per-marker IPPE_SQUARE + estimate_brick_pose, one marker hidden", paper, True),
        ("plain OpenCV: SUBPIX corners, per-marker IPPE_SQUARE, midpoint", opencv_plain, False),
    ):
        print(name)
        run(method, args.frames, args.seed, hide, blur, args.height)


if __name__ == "__main__":
    main()
