"""Perception: the paper's brick pose estimation (pure math here) and, in submodules, ArUco on images.

The names below import only numpy; the OpenCV parts (``masonry.perception.aruco``, ``.render``) import cv2, so
they are never imported eagerly here.
"""

from __future__ import annotations

from masonry.perception.estimation import (
    C_TH,
    EstimatorConfig,
    PoseWindow,
    estimate_brick_pose,
    marker_cost,
    refine_markers,
    refine_markers_bfgs,
    yaw_about_rad,
)
from masonry.perception.types import DEFAULT_INTRINSICS, BrickEstimate, CameraIntrinsics, TagPose

__all__ = [
    "C_TH",
    "DEFAULT_INTRINSICS",
    "BrickEstimate",
    "CameraIntrinsics",
    "EstimatorConfig",
    "PoseWindow",
    "TagPose",
    "estimate_brick_pose",
    "marker_cost",
    "refine_markers",
    "refine_markers_bfgs",
    "yaw_about_rad",
]

# --- OpenCV front end (image-perception engineer): lazy, so ``import masonry.perception`` does not load cv2. ---
_LAZY = {
    "DetectedMarker": "masonry.perception.aruco",
    "aruco_dictionary": "masonry.perception.aruco",
    "detect_markers": "masonry.perception.aruco",
    "detect_tags": "masonry.perception.aruco",
    "estimate_bricks": "masonry.perception.aruco",
    "RenderedBrick": "masonry.perception.render",
    "look_down": "masonry.perception.render",
    "random_view": "masonry.perception.render",
    "render_frame": "masonry.perception.render",
    "ChessboardSpec": "masonry.perception.calibration",
    "calibrate_chessboard": "masonry.perception.calibration",
    "read_calibration": "masonry.perception.calibration",
    "write_calibration": "masonry.perception.calibration",
    "write_marker_sheets": "masonry.perception.markers_sheet",
}


def __getattr__(name: str) -> object:
    """Import the OpenCV-based names on first use (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'masonry.perception' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
