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
from masonry.perception.types import BrickEstimate, CameraIntrinsics, TagPose

__all__ = [
    "C_TH",
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
