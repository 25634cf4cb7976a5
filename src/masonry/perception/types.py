"""Perception values: camera intrinsics, marker poses and brick estimates (camera frame: x right, y down, z forward)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics in pixels plus OpenCV distortion (k1, k2, p1, p2, k3) and image size."""

    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)
    width_px: int = 640
    height_px: int = 480

    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def dist_coeffs(self) -> np.ndarray:
        return np.asarray(self.distortion, dtype=float)


DEFAULT_INTRINSICS = CameraIntrinsics(fx=500.0, fy=500.0, cx=319.5, cy=239.5, width_px=640, height_px=480)
"""640x480, 500 px focal length: about 65 degrees horizontal field of view (the simulated and the fake camera)."""


@dataclass(frozen=True, eq=False)
class TagPose:
    """Pose of one ArUco marker in the camera frame: centre ``position_m`` (3,), rotation ``R_cam_marker`` (3, 3).

    The marker frame: x along the printed image's x axis, y toward the image top, z out of the printed face.
    """

    marker_id: int
    position_m: np.ndarray
    R_cam_marker: np.ndarray


@dataclass(frozen=True, eq=False)
class BrickEstimate:
    """One estimate of a brick's top-face centre and yaw in the frame of its inputs."""

    brick_id: int
    center_m: np.ndarray
    yaw_rad: float
    tags: tuple[int, ...]
