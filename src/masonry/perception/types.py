"""Perception values: camera intrinsics, marker poses and brick estimates (camera frame: x right, y down, z forward)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

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


@dataclass(frozen=True)
class AsBuiltPose:
    """A placed brick as the camera saw it after the release (issue 30's as-built pose).

    ``position_m``: the brick's centre (world, m; the blueprint's ``position`` is its designed value),
    ``yaw_rad``: its yaw, ``deviation_m``: the distance from ``position_m`` to the designed centre,
    ``confidence``: the paper's C of the window of estimates it is the mean of (0..1).

    Relative to the wall (``masonry.fsm.relative_look``; all None when no brick on the wall was seen with it):
    ``relative_to``: the neighbour's brick id, ``relative_offset_m``: the brick's top-face centre less the
    neighbour's as seen in the same frames (world axes, m; the position source's error cancels),
    ``relative_deviation_m``: that offset's distance from the designed one (m); ``relative_offsets``: the offset from
    every neighbour seen in two frames or more, ``(brick id, offset (m), frames)`` by brick id (the reference among
    them; () from a UAV that reports only the reference), which mission control combines over the wall
    (:mod:`masonry.planner.wall_solve`).

    On the wall (mission control, :mod:`masonry.planner.wall_anchor`; both None when the pose is the world-frame
    look as the UAV sent it): ``world_position_m``: the camera's world-frame look, which ``position_m`` then
    replaces (the wall's solve: its sightings and every look; on no survey the wall sits where its looks' mean
    puts it), ``anchored_to``: the surveyed brick (the blueprint's ``placed``) its sightings reach, if any.
    """

    position_m: tuple[float, float, float]
    yaw_rad: float
    deviation_m: float
    confidence: float
    relative_to: int | None = None
    relative_offset_m: tuple[float, float, float] | None = None
    relative_deviation_m: float | None = None
    anchored_to: int | None = None
    world_position_m: tuple[float, float, float] | None = None
    relative_offsets: tuple[tuple[int, tuple[float, float, float], int], ...] = ()
    #: times its UAV re-seated it (lifted it and placed it again: ``UavConfig.reseat_over_m``); the pose is the look
    #: after the last placement
    reseats: int = 0

    def to_dict(self, digits: int | None = None) -> dict[str, object]:
        """``{position_m, yaw_rad, deviation_m, confidence}`` and, with a neighbour seen, ``{relative_to,
        relative_offset_m, relative_deviation_m}`` (``digits``: metres and radians rounded to it, the confidence to
        3; None: exact, the form of the wire and the journal, which alone carry ``relative_offsets``)."""

        def r(v: float, nd: int | None = digits) -> float:
            return v if nd is None else round(v, nd)

        out: dict[str, object] = {
            "position_m": [r(v) for v in self.position_m],
            "yaw_rad": r(self.yaw_rad),
            "deviation_m": r(self.deviation_m),
            "confidence": r(self.confidence, None if digits is None else 3),
        }
        if self.relative_to is not None and self.relative_offset_m is not None:
            out["relative_to"] = self.relative_to
            out["relative_offset_m"] = [r(v) for v in self.relative_offset_m]
            out["relative_deviation_m"] = r(self.relative_deviation_m or 0.0)
            if (
                self.relative_offsets and digits is None
            ):  # (the wire's and the journal's: what a re-solve needs)
                out["relative_offsets"] = [[b, [r(v) for v in o], n] for b, o, n in self.relative_offsets]
        if self.world_position_m is not None:
            if self.anchored_to is not None:
                out["anchored_to"] = self.anchored_to
            out["world_position_m"] = [r(v) for v in self.world_position_m]
        if self.reseats:
            out["reseats"] = self.reseats
        return out

    @classmethod
    def from_dict(cls, data: object) -> AsBuiltPose:
        """The pose :meth:`to_dict` wrote.

        Raises:
            ValueError: not such a mapping (a field missing, not a number, not finite, a confidence off 0..1).
        """
        if not isinstance(data, dict):
            raise ValueError(f"an as-built pose must be an object, got {type(data).__name__}")
        pose = cls._from_dict(data)
        reseats = data.get("reseats", 0)
        if isinstance(reseats, bool) or not isinstance(reseats, int) or reseats < 0:
            raise ValueError(f"an as-built pose's reseats must be an integer >= 0: {data!r}")
        return replace(pose, reseats=reseats) if reseats else pose

    @classmethod
    def _from_dict(cls, data: object) -> AsBuiltPose:
        """:meth:`from_dict` but for ``reseats``."""
        if not isinstance(data, dict):
            raise ValueError(f"an as-built pose must be an object, got {type(data).__name__}")
        try:
            x, y, z = (float(v) for v in data["position_m"])
            yaw, dev, conf = (float(data[k]) for k in ("yaw_rad", "deviation_m", "confidence"))
        except KeyError as exc:
            raise ValueError(f"an as-built pose has no {exc.args[0]!r}") from None
        except (TypeError, ValueError):
            raise ValueError(f"an as-built pose's fields must be numbers: {data!r}") from None
        if not all(map(math.isfinite, (x, y, z, yaw, dev, conf))) or dev < 0.0 or not 0.0 <= conf <= 1.0:
            raise ValueError(f"an as-built pose out of range: {data!r}")
        if data.get("relative_to") is None:
            return _world(cls((x, y, z), yaw, dev, conf), data)
        try:
            ref = data["relative_to"]
            if isinstance(ref, bool) or not isinstance(ref, int) or ref < 0:
                raise TypeError(ref)
            ox, oy, oz = (float(v) for v in data["relative_offset_m"])
            rdev = float(data["relative_deviation_m"])
        except KeyError as exc:
            raise ValueError(f"an as-built pose with relative_to has no {exc.args[0]!r}") from None
        except (TypeError, ValueError):
            raise ValueError(f"an as-built pose's relative fields are malformed: {data!r}") from None
        if not all(map(math.isfinite, (ox, oy, oz, rdev))) or rdev < 0.0:
            raise ValueError(f"an as-built pose's relative fields out of range: {data!r}")
        pose = cls((x, y, z), yaw, dev, conf, ref, (ox, oy, oz), rdev, relative_offsets=_offsets(data))
        if data.get("anchored_to") is None:
            return _world(pose, data)
        try:
            anchor = data["anchored_to"]
            if isinstance(anchor, bool) or not isinstance(anchor, int) or anchor < 0:
                raise TypeError(anchor)
            wx, wy, wz = (float(v) for v in data["world_position_m"])
        except KeyError as exc:
            raise ValueError(f"an as-built pose with anchored_to has no {exc.args[0]!r}") from None
        except (TypeError, ValueError):
            raise ValueError(f"an as-built pose's anchor fields are malformed: {data!r}") from None
        if not all(map(math.isfinite, (wx, wy, wz))):
            raise ValueError(f"an as-built pose's world position out of range: {data!r}")
        return replace(pose, anchored_to=anchor, world_position_m=(wx, wy, wz))


def _world(pose: AsBuiltPose, data: dict[str, object]) -> AsBuiltPose:
    """``pose`` with ``data``'s ``world_position_m`` (a pose on the wall's own looks, no survey), if any.

    Raises:
        ValueError: a malformed one.
    """
    raw = data.get("world_position_m")
    if raw is None:
        return pose
    try:
        if not isinstance(raw, (list, tuple)):
            raise TypeError(raw)
        wx, wy, wz = (float(v) for v in raw)
    except (TypeError, ValueError):
        raise ValueError(f"an as-built pose's world position is malformed: {data!r}") from None
    if not all(map(math.isfinite, (wx, wy, wz))):
        raise ValueError(f"an as-built pose's world position out of range: {data!r}")
    return replace(pose, world_position_m=(wx, wy, wz))


#: The most neighbours an as-built pose's ``relative_offsets`` may hold (a camera sees a few dozen bricks at most).
MAX_RELATIVE_OFFSETS = 64


def _offsets(data: dict[str, object]) -> tuple[tuple[int, tuple[float, float, float], int], ...]:
    """A pose's optional ``relative_offsets`` ([[brick id, [dx, dy, dz], frames], ...]; () when absent).

    Raises:
        ValueError: malformed (not such pairs, a number not finite, a frame count under 1, over
            :data:`MAX_RELATIVE_OFFSETS` of them).
    """
    raw = data.get("relative_offsets")
    if raw is None:
        return ()
    if not isinstance(raw, list) or len(raw) > MAX_RELATIVE_OFFSETS:
        raise ValueError(
            f"an as-built pose's relative_offsets must be a list of at most {MAX_RELATIVE_OFFSETS}"
        )
    out = []
    for item in raw:
        try:
            bid, offset, frames = item
            ox, oy, oz = (float(v) for v in offset)
            if (
                any(isinstance(v, bool) or not isinstance(v, int) for v in (bid, frames))
                or bid < 0
                or frames < 1
            ):
                raise TypeError(item)
        except (TypeError, ValueError):
            raise ValueError(f"an as-built pose's relative_offsets are malformed: {item!r}") from None
        if not all(map(math.isfinite, (ox, oy, oz))):
            raise ValueError(f"an as-built pose's relative_offsets out of range: {item!r}")
        out.append((bid, (ox, oy, oz), frames))
    return tuple(out)
