"""The camera's projection of the rows it may see gives the tags the whole layout's projection gave (issue 27).

``observe_markers`` drops the rows a kept ``covered`` answer says covered before projecting
(:meth:`masonry.sim.camera.LayoutCache.maybe_seen`), tests its rows' four corners with one word per row
(``_rows_all``) and measures the sides of the rows still in view only. Each must leave the frame's tags as they
were: the same markers, the same floats, the same draws (docs/performance/mission.md, branch simspeed35).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import Brick, MarkerSpec
from masonry.geometry import R_world_body
from masonry.perception.types import TagPose
from masonry.sim.bricks import BrickField, SimBrick
from masonry.sim.camera import (
    _NEXT_CORNER,
    CameraConfig,
    LayoutCache,
    _behind,
    _rows_all,
    marker_layout,
    observe_markers,
)


def _observe_as_it_was(R_wc, c_w, bricks, markers, config, rng, *, covered=None, occluder=None):  # type: ignore[no-untyped-def]
    """``observe_markers`` before this change (main at f02e937), without a kept layout: every row projected."""
    intr = config.intrinsics
    ids, centres, corners = marker_layout(bricks, markers)
    p_c = (centres - c_w) @ R_wc
    q_c = (corners - c_w) @ R_wc
    z = q_c[:, :, 2]
    ok = np.all(z > 0.05, axis=1)
    zs = np.where(z > 0.05, z, 1.0)
    u = intr.fx * q_c[:, :, 0] / zs + intr.cx
    v = intr.fy * q_c[:, :, 1] / zs + intr.cy
    ok &= np.all((u >= 0.0) & (u <= intr.width_px - 1.0) & (v >= 0.0) & (v <= intr.height_px - 1.0), axis=1)
    dist = np.linalg.norm(p_c, axis=1)
    cos_view = -(p_c @ R_wc[2, :]) / np.maximum(dist, 1e-9)
    ok &= cos_view >= math.cos(config.max_view_angle_rad)
    side = np.hypot(u[:, _NEXT_CORNER] - u, v[:, _NEXT_CORNER] - v)
    ok &= side.min(axis=1) >= config.min_marker_px
    index = np.flatnonzero(ok)
    if covered is not None and len(index):
        index = np.array([i for i in index if not covered(*centres[i].tolist())], dtype=int)
    if occluder is not None and len(index):
        index = np.array([i for i in index if not _behind(occluder, c_w, centres[i])], dtype=int)
    if not len(index):
        return ()
    d = dist[index]
    noise = rng.standard_normal((len(index), 6))
    lat = config.lateral_noise_m + config.lateral_noise_per_m * d
    dep = config.depth_noise_m + config.depth_noise_per_m * d
    ang = config.angle_noise_rad + config.angle_noise_per_m * d
    pos = p_c[index] + noise[:, :3] * np.stack([lat, lat, dep], axis=1)
    yaw = np.repeat(np.array([b.yaw_rad for b in bricks]), 2)[index]
    cy, sy = np.cos(yaw), np.sin(yaw)
    R_wm = np.zeros((len(index), 3, 3))
    R_wm[:, 0, 0], R_wm[:, 0, 1], R_wm[:, 1, 0], R_wm[:, 1, 1], R_wm[:, 2, 2] = cy, -sy, sy, cy, 1.0
    R = np.einsum("ji,njk,nkl->nil", R_wc, R_wm, _rotvecs_as_they_were(noise[:, 3:] * ang[:, None]))
    return tuple(TagPose(int(ids[i]), pos[row], R[row]) for row, i in enumerate(index))


def _rotvecs_as_they_were(w):  # type: ignore[no-untyped-def]
    """``_rotvecs_to_matrices`` before this change (main at f02e937)."""
    theta = np.linalg.norm(w, axis=1)
    safe = np.where(theta > 1e-12, theta, 1.0)
    k = w / safe[:, None]
    K = np.zeros((len(w), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    sin = np.where(theta > 1e-12, np.sin(theta), 0.0)[:, None, None]
    cos = np.where(theta > 1e-12, 1.0 - np.cos(theta), 0.0)[:, None, None]
    return np.eye(3)[None] + sin * K + cos * (K @ K)


def _wall(courses: int, per_course: int) -> BrickField:
    """A running bond of ``courses`` x ``per_course`` bricks 0.3 m long: every course but the top covers the
    markers of the one under it."""
    field = BrickField(0.5)
    size = (0.3, 0.15, 0.1)
    for c in range(courses):
        for i in range(per_course):
            b = c * per_course + i
            x, z = 0.3 * i + (0.15 if c % 2 else 0.0), 0.05 + 0.1 * c
            field.add(SimBrick(b, Brick(b, (x, 0.0, z), size), (x, 0.0, z), 0.0, "placed"))
    return field


def _same(fast: tuple[TagPose, ...], slow: tuple[TagPose, ...]) -> bool:
    return [t.marker_id for t in fast] == [t.marker_id for t in slow] and all(
        np.array_equal(a.position_m, b.position_m) and np.array_equal(a.R_cam_marker, b.R_cam_marker)
        for a, b in zip(fast, slow, strict=True)
    )


@settings(max_examples=25, deadline=None)
@given(
    x0=st.floats(0.0, 2.0),
    height=st.floats(0.4, 2.0),
    roll=st.floats(-0.4, 0.4),
    pitch=st.floats(-0.4, 0.4),
    yaw=st.floats(-math.pi, math.pi),
    seed=st.integers(0, 2**16),
)
def test_the_rows_that_may_be_seen_give_the_tags_every_row_gave(x0, height, roll, pitch, yaw, seed):
    # a camera climbing and sliding over a four-course wall, a carried brick among the candidates on some frames
    field, markers, config = _wall(4, 8), MarkerSpec(), CameraConfig()
    cache = LayoutCache()
    field.pick(31, "brick-1")
    carried = field.bricks[31]
    down = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    skipped = 0
    for step in range(10):
        R_wc = R_world_body(roll * (1 - step / 10), pitch, yaw + 0.05 * step) @ down
        c_w = np.array([x0 + 0.03 * step, 0.02 * step, 0.4 + height + 0.05 * step])
        carried.position_m = (float(c_w[0]), float(c_w[1]), float(c_w[2]) - 0.3)
        carried.yaw_rad = 0.1 * step
        resting = sorted(field.near(float(c_w[0]), float(c_w[1]), 2.0), key=lambda b: b.id)
        frame = [*resting, carried] if step % 3 else resting
        layout = cache.layout(frame, markers, field.version)
        pre = cache.maybe_seen()
        skipped += 0 if pre is None else 2 * len(frame) - len(pre)
        occluder = carried if step % 3 else None
        fast = observe_markers(
            R_wc, c_w, frame, markers, config, np.random.default_rng(seed + step), occluder=occluder,
            covered=field.covered_kept, layout=layout, kept=cache,
        )  # fmt: skip
        slow = _observe_as_it_was(
            R_wc, c_w, frame, markers, config, np.random.default_rng(seed + step), covered=field.covered_at,
            occluder=occluder,
        )  # fmt: skip
        assert _same(fast, slow)
        plain = observe_markers(R_wc, c_w, frame, markers, config, np.random.default_rng(seed))
        assert _same(
            plain, _observe_as_it_was(R_wc, c_w, frame, markers, config, np.random.default_rng(seed))
        )
    if height < 1.0 and abs(roll) < 0.2 and abs(pitch) < 0.2:
        assert skipped > 0  # (a low camera over the wall sees covered markers: the later frames drop them)


@settings(max_examples=200, deadline=None)
@given(
    m=st.integers(2, 400),
    seed=st.integers(0, 2**32 - 1),
    share=st.floats(0.0, 1.0),
    scale=st.floats(0.01, 50.0),
)
def test_each_projected_row_is_its_own_whatever_the_rows_beside_it(m, seed, share, scale):
    # (what dropping rows before projecting needs: numpy's products give a row the same floats with or without
    # the others, for two rows or more; one row alone takes numpy's other path for the matrix-vector product, and
    # LayoutCache.maybe_seen never leaves one)
    rng = np.random.default_rng(seed)
    points, corners = rng.normal(size=(m, 3)) * scale, rng.normal(size=(m, 4, 3)) * scale
    c_w = rng.normal(size=3)
    R = R_world_body(*rng.uniform(-math.pi, math.pi, size=3))
    rows = np.flatnonzero(rng.random(m) < share)
    if len(rows) < 2:
        rows = np.array([0, m - 1])
    p_all, p_rows = (points - c_w) @ R, (points[rows] - c_w) @ R
    assert np.array_equal(p_all[rows], p_rows)
    assert np.array_equal(((corners - c_w) @ R)[rows], (corners[rows] - c_w) @ R)
    assert np.array_equal((p_all @ R[2, :])[rows], p_rows @ R[2, :])
    assert np.array_equal(
        np.linalg.norm(p_all, axis=1)[rows], np.sqrt(np.add.reduce(p_rows * p_rows, axis=1))
    )


@given(st.lists(st.lists(st.booleans(), min_size=4, max_size=4), max_size=30))
def test_all_four_by_one_word_is_all_of_the_row(table):
    b = np.array(table, dtype=bool).reshape(-1, 4)
    assert np.array_equal(_rows_all(b.copy()), np.all(b, axis=1))
    sides = np.where(
        b, 12.0, 3.0
    )  # (the sides' test: the smallest at least the limit is all four at least it)
    assert np.array_equal(_rows_all(sides >= 10.0), sides.min(axis=1) >= 10.0) if len(b) else True
