"""Physical layout of the two UAV types: where the end-effector, the nozzle and the camera sit on the body.

Body frame: origin at the UAV's reported position, x forward, y left, z up (FLU); yaw rotates it about world z.
Both the state machines (to aim the tool) and the simulator (to move the brick / deposit adhesive) use these
values, so they agree by construction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

Vec3 = tuple[float, float, float]


def camera_mount(offset_m: Vec3 = (0.10, 0.0, -0.05)) -> np.ndarray:
    """4x4 pose of a downward camera in the body frame: optical axis (cam z) along body -z, cam x along body x.

    The camera's y axis (image down) then points along body -y (right-handed: a 180 degree roll).
    """
    T = np.eye(4)
    T[:3, :3] = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    T[:3, 3] = offset_m
    return T


@dataclass(frozen=True)
class Airframe:
    """Tool and sensor placement on one UAV (body frame, metres)."""

    effector_offset_m: Vec3 = (0.0, 0.0, -0.45)  # electromagnet tip on the rod below the body (brick UAV)
    nozzle_offset_m: Vec3 = (0.0, 0.0, -0.35)  # spray nozzle outlet (adhesion UAV)
    camera_offset_m: Vec3 = (0.10, 0.0, -0.05)
    grasp_tolerance_m: float = 0.03  # the conical guide forgives about 3 cm (paper, Section IV)
    spray_height_m: float = 0.10  # nozzle height above the surface while spraying
    span_m: float = 0.8  # propeller tip to tip: what a landed UAV needs beside it (masonry.separation)

    def T_body_cam(self) -> np.ndarray:
        return camera_mount(self.camera_offset_m)


DEFAULT_AIRFRAME = Airframe()
