"""The site's geofence (issue 18, section 2): the blueprint's `site`, its geometry, the airspace's grants, the
machines' clamp and breach handling, in the simulated world under a push toward the fence."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from hypothesis import example, given, seed, settings
from hypothesis import strategies as st

from masonry.blueprint import format_blueprint, load_blueprint, parse_blueprint
from masonry.errors import BlueprintError
from masonry.geofence import SETPOINT_MARGIN_M, Site, simple_polygon_problem
from masonry.mission.airspace import ColumnClearance
from masonry.mission.fence import volumes_in_fence
from masonry.mission.simulate import SimulatedMission
from masonry.site_checks import highest_transit_layer_m

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
#: The case study's site, 1 m beyond the pickups (x = 3) on the +x side: the tightest validation allows.
TIGHT = "site: {boundary: [[-2, -4], [4, -4], [4, 2.5], [-2, 2.5]], max_altitude: 6}\n"
#: A notch between the wall (x = 0) and the pallet (x = 3): the straight transport leg leaves the site.
NOTCH = (
    "site: {boundary: [[-2, -4], [5, -4], [5, 2.5], [1.8, 2.5], [1.8, -1.5], [1.2, -1.5], [1.2, 2.5], "
    "[-2, 2.5]], max_altitude: 6}\n"
)


def _with_site(tmp_path: Path, site: str, name: str = "wall.yaml") -> Path:
    path = tmp_path / name
    path.write_text(CASE_STUDY.read_text() + site)
    return path


# -- the blueprint -----------------------------------------------------------------------------------------


def test_a_site_loads_and_round_trips(tmp_path: Path) -> None:
    bp = load_blueprint(_with_site(tmp_path, TIGHT))
    assert bp.site == Site(((-2.0, -4.0), (4.0, -4.0), (4.0, 2.5), (-2.0, 2.5)), 6.0)
    again = tmp_path / "again.yaml"
    again.write_text(format_blueprint(bp))
    assert dataclasses.replace(load_blueprint(again), source=bp.source) == bp


def test_a_clockwise_boundary_is_as_good() -> None:
    bp = load_blueprint(CASE_STUDY)
    raw = {
        "bricks": [{"id": b.id, "position": list(b.position_m), "placed": True} for b in bp.bricks],
        "fleet": [{"name": u.name, "role": u.role, "home": list(u.home_m)} for u in bp.fleet],
        "site": {"boundary": [[-2, 2.5], [4, 2.5], [4, -4], [-2, -4]], "max_altitude": 6},
    }
    site = parse_blueprint(raw, "cw.yaml").site
    assert site is not None and site.signed_area_m2() < 0
    assert site.inside_m(0.0, 0.0) == pytest.approx(2.0)


def test_no_site_is_as_before() -> None:
    bp = load_blueprint(CASE_STUDY)
    assert bp.site is None and "site" not in format_blueprint(bp)


@pytest.mark.parametrize(
    "site,where,says",
    [
        ("site: [1, 2]\n", "site", "must be a mapping"),
        ("site: {boundary: [[0, 0], [1, 0], [1, 1]]}\n", "site", "missing key 'max_altitude'"),
        ("site: {boundry: [], max_altitude: 5}\n", "site", "did you mean 'boundary'"),
        ("site: {boundary: [[-2, -4], [4, -4]], max_altitude: 6}\n", "site.boundary", "at least 3"),
        ("site: {boundary: [[-2, -4], [4, -4], [4, .nan]], max_altitude: 6}\n", "site.boundary[2]", "finite"),
        ("site: {boundary: [[-2, -4], [4, -4], [4]], max_altitude: 6}\n", "site.boundary[2]", "[x, y]"),
        ("site: {boundary: [[-2, -4], [4, 2.5], [4, -4], [-2, 2.5]], max_altitude: 6}\n", "site.boundary", "cross"),
        ("site: {boundary: [[-2, -4], [-2, -4], [4, 2.5]], max_altitude: 6}\n", "site.boundary", "same point"),
        ("site: {boundary: [[-2, -4], [4, -4], [4, 2.5], [-2, 2.5]], max_altitude: .inf}\n", "site.max_altitude", "finite"),
        ("site: {boundary: [[-2, -4], [4, -4], [4, 2.5], [-2, 2.5]], max_altitude: 3.5}\n", "site.max_altitude", "highest transit layer"),
        ("site: {boundary: [[-2, -4], [3.5, -4], [3.5, 2.5], [-2, 2.5]], max_altitude: 6}\n", "brick 0: pickup", "only 0.5 m inside"),
        ("site: {boundary: [[-0.5, -4], [4, -4], [4, 2.5], [-0.5, 2.5]], max_altitude: 6}\n", "brick 2", "0.35 m inside"),
        ("site: {boundary: [[-2, -2], [4, -2], [4, 2.5], [-2, 2.5]], max_altitude: 6}\n", "fleet UAV 'brick-1': home", "0.5 m outside"),
    ],
)  # fmt: skip
def test_a_bad_site_is_one_line_naming_the_field(tmp_path: Path, site: str, where: str, says: str) -> None:
    path = _with_site(tmp_path, site)
    with pytest.raises(BlueprintError) as info:
        load_blueprint(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {where}: "), message
    assert says in message and "\n" not in message


def test_the_cli_exits_2_on_a_bad_site(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from masonry.cli import app

    path = _with_site(tmp_path, "site: {boundary: [[0, 0], [1, 0], [1, 1]], max_altitude: 6}\n")
    result = CliRunner().invoke(app, ["plan", str(path)])
    assert result.exit_code == 2
    assert f"{path}: brick 2: " in result.output and "outside the site boundary" in result.output


def test_max_altitude_is_checked_against_the_airspaces_highest_layer() -> None:
    from masonry.mission.altitudes import transit_layers_m

    bp = load_blueprint(CASE_STUDY)
    assert highest_transit_layer_m(bp) == pytest.approx(max(transit_layers_m(bp).values()))


# -- the geometry ------------------------------------------------------------------------------------------

L_SHAPE = Site(((0.0, 0.0), (6.0, 0.0), (6.0, 2.0), (2.0, 2.0), (2.0, 6.0), (0.0, 6.0)), 10.0)


@st.composite
def _polygons(draw: st.DrawFn) -> Site:
    """A convex polygon (regular, stretched, rotated, either orientation) or the L shape, moved anywhere."""
    if draw(st.booleans()):
        pts = list(L_SHAPE.boundary_m)
    else:
        n = draw(st.integers(3, 9))
        r = draw(st.floats(4.0, 30.0))  # a site with room inside it (a triangle's inradius r/2)
        stretch = draw(st.floats(0.5, 1.0))
        turn = draw(st.floats(0.0, math.tau))
        pts = [
            (r * math.cos(turn + k * math.tau / n), stretch * r * math.sin(turn + k * math.tau / n))
            for k in range(n)
        ]
    if draw(st.booleans()):
        pts.reverse()
    dx, dy = draw(st.floats(-500, 500)), draw(st.floats(-500, 500))
    return Site(tuple((x + dx, y + dy) for x, y in pts), draw(st.floats(3.0, 50.0)))


@seed(18)
@settings(max_examples=150, deadline=None)
@given(site=_polygons(), u=st.floats(-1.5, 1.5), v=st.floats(-1.5, 1.5), z=st.floats(0.0, 80.0))
@example(  # a vertex a subnormal above the ray: recomputing its y as start + direction put it on the other side
    site=Site(
        (
            (23.0, 5e-324),
            (21.0, 2.598076211353316),
            (17.0, 2.598076211353316),
            (15.0, 3.6739403974420594e-16),
            (17.0, -2.598076211353315),
            (21.0, -2.598076211353316),
        ),
        3.0,
    ),
    u=0.0,
    v=0.0,
    z=0.0,
)
def test_clamp_keeps_points_inside_by_the_margin_and_leaves_inner_ones_alone(site, u, v, z) -> None:
    assert simple_polygon_problem(site.boundary_m) is None
    xs = [p[0] for p in site.boundary_m]
    ys = [p[1] for p in site.boundary_m]
    cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
    p = (cx + u * (max(xs) - min(xs)), cy + v * (max(ys) - min(ys)), z)
    c = site.clamp_m(p, SETPOINT_MARGIN_M)
    assert all(math.isfinite(w) for w in c)
    assert site.inside_m(c[0], c[1]) >= SETPOINT_MARGIN_M - 1e-6, (p, c)
    assert c[2] <= site.max_altitude_m - SETPOINT_MARGIN_M + 1e-9
    assert site.clamp_m(c, SETPOINT_MARGIN_M) == pytest.approx(c, abs=1e-9)  # idempotent
    if site.inside_m(p[0], p[1]) >= SETPOINT_MARGIN_M and z <= site.max_altitude_m - SETPOINT_MARGIN_M:
        assert c == p
    # never much farther than it must be: the way in to the margin, plus what the sharpest corner adds (its inner
    # offset corner lies margin / sin(half its angle) from it), plus a quarter (alternating projections land on
    # the inner offset, not always at its nearest point)
    bound = max(0.0, SETPOINT_MARGIN_M - site.inside_m(p[0], p[1])) + SETPOINT_MARGIN_M / math.sin(
        _sharpest_half_angle_rad(site)
    )
    assert math.hypot(c[0] - p[0], c[1] - p[1]) <= 1.25 * bound + 1e-6


def _sharpest_half_angle_rad(site: Site) -> float:
    pts = site.boundary_m
    n = len(pts)
    half = math.pi / 2
    for i in range(n):
        (px, py), (cx, cy), (qx, qy) = pts[i - 1], pts[i], pts[(i + 1) % n]
        a = math.atan2(py - cy, px - cx) - math.atan2(qy - cy, qx - cx)
        angle = abs(math.remainder(a, math.tau))
        half = min(half, angle / 2)
    return half


def test_inside_and_outside_of_the_l_shape() -> None:
    assert L_SHAPE.inside_m(1.0, 1.0) == pytest.approx(1.0)
    assert L_SHAPE.inside_m(4.0, 4.0) == pytest.approx(-2.0)  # the notch of the L
    assert L_SHAPE.outside_by_m((4.0, 4.0, 1.0)) == pytest.approx(2.0)
    assert L_SHAPE.outside_by_m((1.0, 1.0, 12.0)) == pytest.approx(2.0)  # above the altitude limit
    assert not L_SHAPE.segment_inside((1.0, 5.0), (5.0, 1.0))  # across the notch
    assert L_SHAPE.segment_inside((1.0, 5.0), (1.0, 1.0), 0.5)
    # the notch's centre is 2 m from both of its edges: either arm's side, 0.5 m in
    assert L_SHAPE.clamp_m((4.0, 4.0, 1.0), 0.5) in ((1.5, 4.0, 1.0), (4.0, 1.5, 1.0))


# -- the airspace ------------------------------------------------------------------------------------------


def test_a_flight_across_the_fence_is_refused_with_the_reason_and_one_inside_granted() -> None:
    c = ColumnClearance(1.5, base_m=1.5, homes={"a": (1.0, 5.0, 0.0), "b": (5.0, 1.0, 0.0)}, fence=L_SHAPE)
    assert c.take_off("a")
    g = c.request("a", (5.0, 1.0, 1.0), 0.0, position_m=(1.0, 5.0, 1.5))
    assert not g.granted and g.hold_m is None
    assert g.refused is not None and "leaves the site fence" in g.refused
    ok = c.request("a", (1.0, 1.0, 1.0), 1.0, position_m=(1.0, 5.0, 1.5))
    assert ok.granted and ok.refused is None
    assert volumes_in_fence(L_SHAPE, c.volumes("a"))


def test_no_layer_above_the_altitude_limit_is_granted() -> None:
    site = Site(((-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)), 3.0)
    c = ColumnClearance(1.5, base_m=1.5, homes={"a": (-5.0, 0.0, 0.0), "b": (5.0, 0.0, 0.0)}, fence=site)
    assert c.take_off("a") and c.take_off("b")
    assert c.request("a", (5.0, 3.0, 1.0), 0.0, position_m=(-5.0, 0.0, 1.5)).granted  # layer 0 at 1.5 m
    # b's flight crosses a's at layer 0; layer 1 (2.6 m) would come within 0.5 m of the 3 m limit: no grant
    g = c.request("b", (-5.0, 3.0, 1.0), 0.0, position_m=(5.0, 0.0, 1.5))
    assert not g.granted and g.refused is None
    for v in c.volumes("b"):
        assert v.z1_m <= site.max_altitude_m - 0.5
    assert c.conflicts() == []


@seed(18)
@settings(max_examples=60, deadline=None)
@given(
    requests=st.lists(
        st.tuples(st.sampled_from("abc"), st.floats(0.3, 5.7), st.floats(0.3, 5.7), st.floats(0.5, 4.0)),
        min_size=1,
        max_size=25,
    )
)
def test_every_volume_granted_keeps_inside_the_fence(requests) -> None:
    homes = {"a": (1.0, 1.0, 0.0), "b": (1.0, 4.5, 0.0), "c": (4.5, 1.0, 0.0)}
    c = ColumnClearance(1.5, base_m=1.5, homes=homes, fence=L_SHAPE)
    where = {u: (h[0], h[1], 1.5) for u, h in homes.items()}
    for u in homes:
        c.take_off(u)
    for t, (u, x, y, z) in enumerate(requests):
        g = c.request(u, (x, y, z), float(t), position_m=where[u])
        inside = L_SHAPE.inside_m(x, y)
        if g.granted:
            assert inside >= 0.5 + c.zone_slack_m - 1e-9
            c.end_transit(u)
            where[u] = (x, y, z)
        for v in c.volumes(u):
            if v.kind in ("leg", "hover") or (v.kind == "zone" and g.granted):
                assert volumes_in_fence(L_SHAPE, [v]), (u, v)
        assert c.conflicts() == []


# -- the machines and the mission --------------------------------------------------------------------------


def _fly_pushed(path: Path, push_mps2: float, vehicle: str):
    """The whole mission with every UAV pushed in +x (toward the fence) all the time; the worst excursion."""
    bp = load_blueprint(path)
    mission = SimulatedMission.from_blueprint(bp, seed=1, vehicle=vehicle)
    world = mission.world
    for u in world.uavs.values():
        u.vehicle.push_mps2 = (push_mps2, 0.0)
    worst = dict.fromkeys(world.uavs, -math.inf)
    step = world.step

    def spy(dt_s: float) -> None:
        step(dt_s)
        for name, u in world.uavs.items():
            v = u.vehicle
            if v.armed and not v.on_ground:
                worst[name] = max(worst[name], bp.site.outside_by_m(v.position_m))  # type: ignore[union-attr]

    world.step = spy  # type: ignore[method-assign]
    return mission.run(), worst, mission


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
def test_the_fence_holds_under_a_push_toward_it(tmp_path: Path, vehicle: str) -> None:
    """A steady 2 m/s^2 push (a 4 m/s wind on the vehicle's drag) toward the fence 1 m beyond the pallet: the
    mission completes and no UAV comes within 0.5 m of the fence (the setpoints keep 0.5 m inside)."""
    report, worst, _ = _fly_pushed(_with_site(tmp_path, TIGHT), 2.0, vehicle)
    assert report.completed
    assert max(worst.values()) < -0.5, worst


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
def test_a_uav_blown_out_of_the_fence_gives_its_task_up_and_lands(tmp_path: Path, vehicle: str) -> None:
    """A push beyond the airframe's authority (3 m/s^2 against its 2.5 m/s^2): each UAV is blown out on its first
    task, which fails saying so (once: no new task while outside), and lands where it is 20 s later."""
    report, _, mission = _fly_pushed(_with_site(tmp_path, TIGHT), 3.0, vehicle)
    assert not report.completed
    reasons = [a.reason for t in report.tasks for a in t.tries if a.status == "failed"]
    assert any(r.startswith("outside the site fence by ") for r in reasons), reasons
    for name, handler in mission.handlers.items():
        model = handler.model
        assert model.state == "halted", (name, model.trace)
        assert model.halt_reason.startswith("could not get back inside the site fence within 20 s")
        assert mission.world.uavs[name].vehicle.on_ground
        fence_failures = [r for r in model.results if r.reason and r.reason.startswith("outside the site")]
        assert len(fence_failures) == 1, model.results


def test_a_task_that_could_only_be_flown_outside_the_fence_fails_saying_why(tmp_path: Path) -> None:
    """The transport leg crosses a notch of the site: each brick task fails its three attempts with the reason
    (the brick put back on its pallet), the adhesion tasks are done, and the mission ends instead of hanging."""
    report, worst, _ = _fly_pushed(_with_site(tmp_path, NOTCH), 0.0, "ideal")
    assert not report.completed and report.stall is None
    by_id = {t.id: t for t in report.tasks}
    assert by_id["A0"].status == by_id["A1"].status == "done"
    for tid in ("B0", "B1"):
        t = by_id[tid]
        assert t.status == "stuck" and len(t.tries) == 3
        for a in t.tries:
            assert "leaves the site fence" in a.reason, a.reason
    assert max(worst.values()) < -0.4, worst


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
@pytest.mark.parametrize("fenced", [True, False])
def test_setpoints_beyond_the_fence_are_clamped_inside_it(tmp_path: Path, vehicle: str, fenced: bool) -> None:
    """A navigator sent 2 m past the fence, pushed toward it at 1.5 m/s^2: with the fence its UAV stops 0.5 m inside
    it and stays there; without, it flies out (so the check can fail)."""
    from masonry.fsm import UavConfig
    from masonry.fsm.navigator import Navigator
    from masonry.fsm.tuning import uav_settings
    from masonry.sim import World
    from masonry.sim.vehicle_config import vehicle_preset
    from sim_helpers import DT_S, take_off

    bp = load_blueprint(_with_site(tmp_path, TIGHT))
    site = bp.site
    assert site is not None
    world = World(bp, seed=2, vehicle=vehicle_preset(vehicle))
    spec = bp.fleet[0]  # brick-1, home (2, -2.5): 2 m from the fence at x = 4
    sim_uav = world.add_uav(spec)
    take_off(world, sim_uav)
    config = UavConfig.from_spec(spec, fence=site if fenced else None, **uav_settings(vehicle))
    nav = Navigator(config)
    sim_uav.vehicle.push_mps2 = (1.5, 0.0)
    tel = sim_uav.fc.telemetry()
    nav.fly_to(world.clock.now_s(), tel, (6.0, -2.5, 1.2))
    worst = -math.inf
    for _ in range(round(30.0 / DT_S)):
        tel = sim_uav.fc.telemetry()
        sp = nav.step(world.clock.now_s(), tel)
        sim_uav.fc.send_velocity(sp.velocity_mps, sp.yaw_rate_radps)
        world.step(DT_S)
        worst = max(worst, site.outside_by_m(sim_uav.vehicle.position_m))
    x = sim_uav.vehicle.position_m[0]
    if fenced:
        # the setpoint 0.5 m inside; the push swings it up to 0.33 m past that on the arducopter preset's lag
        # (measured: 0.5 m inside on ideal, 0.17 m on arducopter), never out
        assert worst < -0.1, worst
        assert x == pytest.approx(4.0 - SETPOINT_MARGIN_M, abs=0.05)
    else:
        assert worst > 1.5 and x > 5.5


def test_masonry_sim_with_a_site_from_the_cli(tmp_path: Path) -> None:
    """`masonry sim` flies a blueprint with a site: the notch's brick tasks fail, the JSON says why."""
    import json

    from typer.testing import CliRunner

    from masonry.cli import app

    result = CliRunner().invoke(app, ["sim", str(_with_site(tmp_path, NOTCH)), "--format", "json"])
    assert result.exit_code == 1, result.output
    report = json.loads(result.stdout)
    b0 = next(t for t in report["tasks"] if t["id"] == "B0")
    assert b0["status"] == "stuck"
    assert all("leaves the site fence" in a["reason"] for a in b0["attempts_detail"])
