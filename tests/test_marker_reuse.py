"""Big walls that fly (issue 30): marker numbers reused where no camera pose sees two alike, proved and used."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from masonry.blueprint import MAX_MARKED_BRICKS, Blueprint, MarkerSpec, format_blueprint, load_blueprint
from masonry.blueprint_gen import pyramid, running_bond, towers
from masonry.cli import app
from masonry.errors import BlueprintError
from masonry.fingerprint import wall_digest
from masonry.fsm.brick_sight import sight_brick
from masonry.marker_reuse import brick_sites, check_marker_reuse, covisible_distance_m, identify_radius_m
from masonry.mission.messages import task_from_dict, task_to_dict
from masonry.mission.pick_audit import audit_picks
from masonry.mission.simulate import SimulatedMission
from masonry.perception.estimation import EstimatorConfig
from masonry.perception.types import DEFAULT_INTRINSICS, TagPose
from masonry.planner import plan
from masonry.ports import CameraFrame, Telemetry
from masonry.sim.bricks import SimBrick
from masonry.sim.camera import CameraConfig, observe_markers


def _shared_pairs_too_close(bp: Blueprint) -> list[tuple[int, int, float]]:
    """Brute force, independent of the checker: pairs of bricks sharing a marker number whose sites are close."""
    limit = covisible_distance_m(bp.markers)
    points, owner, _ = brick_sites(bp.bricks)
    numbers = np.array([b.marker_number for b in bp.bricks])[owner]
    d = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)
    bad = (d <= limit) & (numbers[:, None] == numbers[None, :]) & (owner[:, None] != owner[None, :])
    return [(int(owner[i]), int(owner[j]), float(d[i, j])) for i, j in zip(*np.nonzero(bad))]


_LAYOUTS = st.one_of(
    st.builds(
        lambda c, n, yaw, joint: running_bond(
            c, n, joint_m=joint, yaw_rad=yaw, markers=MarkerSpec("DICT_4X4_100")
        ),
        st.integers(1, 4),
        st.integers(15, 70),
        st.floats(-math.pi, math.pi),
        st.sampled_from([0.0, 0.01, 0.05]),
    ),
    st.builds(
        lambda t, h, s: towers(t, h, spacing_m=s, markers=MarkerSpec("DICT_4X4_50")),
        st.integers(8, 30),
        st.integers(1, 4),
        st.floats(0.4, 3.0),
    ),
    st.builds(lambda b: pyramid(b, markers=MarkerSpec("DICT_4X4_50")), st.integers(7, 12)),
)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(_LAYOUTS)
def test_no_two_covisible_bricks_share_a_marker_number(bp: Blueprint) -> None:
    """Every generated wall beyond its dictionary is numbered with reuse, and no two co-visible bricks share one."""
    if len(bp.bricks) <= ARUCO_PAIRS[bp.markers.dictionary] or bp.bricks[0].marker is None:
        return  # fits its dictionary (ids are the numbers), or the dictionary is too small to reuse in
    assert len({b.marker_number for b in bp.bricks}) < len(bp.bricks), "numbers are reused"
    assert _shared_pairs_too_close(bp) == [], f"wall {bp.name}: {_shared_pairs_too_close(bp)[:3]}"
    check_marker_reuse(bp)
    plan(bp)  # validates for flight


ARUCO_PAIRS = {"DICT_4X4_50": 25, "DICT_4X4_100": 50}
_ROOT = Path(__file__).resolve().parent.parent


@settings(max_examples=40, deadline=None, derandomize=True)
@given(
    x=st.floats(-12.0, 12.0),
    y=st.floats(-5.0, 1.0),
    z=st.floats(0.3, 3.0),
    tilt=st.floats(0.0, 0.4),
    heading=st.floats(-math.pi, math.pi),
    built=st.integers(0, 120),
)
def test_the_camera_model_never_sees_one_marker_number_twice(
    x: float, y: float, z: float, tilt: float, heading: float, built: int
) -> None:
    """The simulated camera, anywhere over a reusing wall part built, sees each ArUco id at most once."""
    bp = _REUSING
    bricks = []
    for k, b in enumerate(bp.bricks):  # the first ``built`` on the wall, the others waiting at their pickups
        if k < built or b.pickup_m is None:
            bricks.append(SimBrick(b.id, b, b.position_m, b.yaw_rad, "placed"))
        else:
            bricks.append(SimBrick(b.id, b, b.pickup_m, 0.3, "pickup"))
    # camera: optical axis down, tilted by ``tilt`` toward ``heading``
    axis = np.array([math.sin(tilt) * math.cos(heading), math.sin(tilt) * math.sin(heading), -math.cos(tilt)])
    right = np.cross(axis, [0.0, 0.0, 1.0]) if tilt > 1e-6 else np.array([1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(axis, right)
    R_wc = np.column_stack([right, down, axis])
    cfg = dataclasses.replace(CameraConfig(), lateral_noise_m=0.0, lateral_noise_per_m=0.0)
    tags = observe_markers(R_wc, np.array([x, y, z]), bricks, bp.markers, cfg, np.random.default_rng(0))
    ids = [t.marker_id for t in tags]
    assert len(ids) == len(set(ids)), sorted(ids)


_REUSING = running_bond(2, 60, markers=MarkerSpec("DICT_4X4_100"))


def test_a_1500_brick_wall_from_masonry_blueprint_validates_for_flight(tmp_path: Path) -> None:
    path = tmp_path / "wall.yaml"
    runner = CliRunner()
    made = runner.invoke(
        app, ["blueprint", "running-bond", "--courses", "5", "--bricks-per-course", "300", "-o", str(path)]
    )
    assert made.exit_code == 0, made.output
    bp = load_blueprint(path)  # validates for flight: marker ids checked
    assert len(bp.bricks) == 1500 > MAX_MARKED_BRICKS
    assert all(b.marker is not None for b in bp.bricks)
    assert (
        len({b.marker for b in bp.bricks}) <= 125 and bp.markers.dictionary == "DICT_4X4_250"
    )  # smallest fitting
    assert _shared_pairs_too_close(bp) == []
    assert "marker: " in path.read_text()


def test_walls_under_the_old_limit_keep_their_ids_as_marker_numbers() -> None:
    bp = running_bond(4, 8, placed_courses=1)
    assert all(b.marker is None for b in bp.bricks)
    assert "marker:" not in format_blueprint(bp)
    assert bp.brick(7).marker_ids() == (14, 15)
    assert all("marker" not in task_to_dict(t) for t in plan(bp).tasks if t.kind == "brick")


def test_a_shared_marker_in_view_is_one_line_naming_the_file_both_bricks_and_a_free_number(
    tmp_path: Path,
) -> None:
    bp = _REUSING
    b5, b6 = bp.brick(5), bp.brick(6)  # neighbours on the wall: always in one view
    bad = dataclasses.replace(
        bp, bricks=tuple(dataclasses.replace(b, marker=b5.marker) if b.id == 6 else b for b in bp.bricks)
    )
    path = tmp_path / "wall.yaml"
    path.write_text(format_blueprint(bad))
    with pytest.raises(BlueprintError) as info:
        load_blueprint(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: brick 6: marker: {b5.marker} (ArUco ids {2 * b5.marker}, ")
    assert "brick 5's too" in message and "one camera pose can see both" in message
    assert "give it marker " in message
    free = int(message.split("give it marker ")[1].split()[0])
    fixed = dataclasses.replace(
        bp, bricks=tuple(dataclasses.replace(b, marker=free) if b.id == 6 else b for b in bp.bricks)
    )
    check_marker_reuse(fixed)  # the number it proposes is free there
    assert b6.marker != b5.marker
    result = CliRunner().invoke(app, ["plan", str(path)])
    assert result.exit_code == 2
    assert result.output.strip().splitlines()[-1].startswith("error: ")
    assert "Traceback" not in result.output


def test_a_marker_beyond_the_dictionary_names_the_brick_and_field(tmp_path: Path) -> None:
    text = format_blueprint(running_bond(1, 3)).replace("{id: 2,", "{id: 2, marker: 40,")
    path = tmp_path / "wall.yaml"
    path.write_text(text)
    with pytest.raises(
        BlueprintError, match=r"brick 2: marker: 40 \(ArUco ids 80, 81\) is not in DICT_4X4_50"
    ):
        load_blueprint(path)


def test_the_marker_number_travels_with_the_task_and_the_digest() -> None:
    bp = _REUSING
    task = next(t for t in plan(bp).tasks if t.kind == "brick" and t.id == "B70")
    assert task.marker == bp.brick(70).marker and task.marker_ids == bp.brick(70).marker_ids()
    assert task_from_dict(task_to_dict(task)) == task
    plain = dataclasses.replace(bp, bricks=tuple(dataclasses.replace(b, marker=None) for b in bp.bricks))
    assert wall_digest(plain) != wall_digest(bp)


class _Camera:
    """A camera that shows the given marker poses (camera frame) once."""

    intrinsics = DEFAULT_INTRINSICS
    T_body_cam = np.eye(4)

    def __init__(self, tags: tuple[TagPose, ...]) -> None:
        self.tags = tags

    def read(self) -> CameraFrame:
        return CameraFrame(time_s=0.0, tags=self.tags)


def test_the_brick_uav_takes_a_marker_for_its_brick_only_near_its_pickup() -> None:
    bp = _REUSING
    task = next(t for t in plan(bp).tasks if t.kind == "brick" and t.id == "B70")
    assert task.pickup_m is not None
    top = np.array(task.pickup_m) + np.array([0.0, 0.0, task.size_m[2] / 2.0])
    # the UAV 1 m over the pickup, camera axes = world axes (identity attitude and mounting): tag position in
    # the camera frame is the world offset from the camera
    tel = Telemetry(0.0, (float(top[0]), float(top[1]), float(top[2]) + 1.0), (0, 0, 0), (0, 0, 0), True, "GUIDED",
                    1.0, True, True, False)  # fmt: skip
    id1, id2 = task.marker_ids
    cam = np.array(tel.position_m)
    half = bp.markers.spacing_m / 2.0

    def tag(marker_id: int, centre: np.ndarray, sign: float) -> TagPose:
        return TagPose(marker_id, centre + np.array([sign * half, 0.0, 0.0]) - cam, np.eye(3))

    radius = identify_radius_m(bp.markers)
    est = EstimatorConfig(spacing_m=bp.markers.spacing_m, up=(0.0, 0.0, 1.0))
    here = _Camera((tag(id1, top, 1.0), tag(id2, top, -1.0)))
    found = sight_brick(here, np.eye(4), tel, task, bp.markers, est, radius)
    assert found is not None and np.allclose(found[0], top, atol=1e-6)
    far = top + np.array(
        [radius + 0.5, 0.0, 0.0]
    )  # the same ids on another brick, beyond the identify radius
    elsewhere = _Camera((tag(id1, far, 1.0), tag(id2, far, -1.0)))
    assert sight_brick(elsewhere, np.eye(4), tel, task, bp.markers, est, radius) is None
    both = _Camera((tag(id1, far, 1.0), tag(id2, far, -1.0), tag(id1, top, 1.0), tag(id2, top, -1.0)))
    found = sight_brick(both, np.eye(4), tel, task, bp.markers, est, radius)
    assert found is not None and np.allclose(found[0], top, atol=1e-6)


def test_a_wall_with_reused_markers_flies_to_completion_with_no_confusion() -> None:
    """30 bricks in DICT_4X4_50 (25 numbers): reused; flown with drawn images at a sample of the pickups."""
    bp = running_bond(1, 30, markers=MarkerSpec("DICT_4X4_50"), brick_uavs=2, adhesion_uavs=1)
    assert len({b.marker for b in bp.bricks}) < 25 < len(bp.bricks)
    with SimulatedMission.from_blueprint(bp, camera="mixed", seed=1) as mission:
        report = mission.run()
        world = mission.world
    assert report.completed
    audit = audit_picks(world.picks, report.attempts, world.drawn_pickups)
    assert audit.confusions == ()
    assert audit.picks == audit.identified >= 30
    assert audit.sampled == audit.sampled_identified >= 5
    assert world.rendered_frames > 0
    assert max(report.placement_error_m.values()) < 0.05


def test_masonry_sim_camera_mixed_draws_the_sampled_pickups() -> None:
    result = CliRunner().invoke(
        app,
        ["sim", str(_ROOT / "blueprints" / "paper_case_study.yaml"), "--camera", "mixed", "--format", "json"],
    )
    assert result.exit_code == 0, result.output
    assert '"completed": true' in result.output
