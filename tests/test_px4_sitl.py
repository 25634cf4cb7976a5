"""The real PX4 v1.16 SITL (issue 29): read from its heartbeat, it gets the ``px4`` tuning without being told, and
a failsafe of its (its geofence) ends `masonry fly`, and its process's death `masonry fly --mission` (in one line);
issue 29's one-brick scenario and the adhesion task A0 fly with default settings (their PX4's EKF2 holding its height
on SIH's range finder: :data:`RANGE_FINDER_PX4_PARAMS`), and so does the case study as a two-vehicle mission (4-6 min
of wall on its own).

Skipped, with one reason, where ``MASONRY_PX4_SITL`` does not name ``../shared/px4/run.sh`` (tests/px4_sitl.py);
``.ci/run`` sets it. SIH runs in real time: each test holds :func:`px4_sitl.one_flight_at_a_time` (the tests' PX4s
never fly beside each other on the two xdist workers) and flies PX4 instances 4-7 (one flight at a time), each
bounded in wall time with a message saying what did not end. Every uav.yaml holds only ``estimate_wait_s: 150``.
"""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path

import pytest

from case_study_procs import CASE_STUDY, check_completed, fly_mission, free_tcp_port, masonry, reaped
from masonry.adapters.mavlink import MAV_CMD_COMPONENT_ARM_DISARM, MavlinkFlightController
from masonry.adapters.wiring import hardware_config
from masonry.blueprint import load_blueprint
from masonry.cli.fly import select_adapters
from masonry.cli.fly_tuning import fly_settings, tuning_preset
from masonry.errors import CommandRejected
from masonry.fsm.tuning import uav_settings
from masonry.sim import Faults
from px4_sitl import (
    ONE_BRICK,
    SIH_STARVED,
    flight_folders,
    give_the_cpu,
    hover,
    kill_px4,
    on_px4,
    one_flight_at_a_time,
    px4,
    px4_log,
    px4_run_sh,
    sih_starved,
    velocity_errors,
)

#: The issue's uav.yaml: PX4's EKF2 is ready within seconds, a loaded machine slows it; nothing else is set.
UAV_YAML = "estimate_wait_s: 150\n"
TUNING_LINE = "[ok  ] tuning: control preset px4 (PX4 autopilot, from its HEARTBEAT)"
#: Wall seconds a single task may take, pre-flight included (the brick task flies 60-140 s; PX4 runs in real time).
TASK_WALL_S = 420.0


@pytest.mark.slow
def test_the_real_px4_is_read_from_its_heartbeat_and_flies_the_px4_tuning(tmp_path: Path, capsys) -> None:
    bp = load_blueprint(CASE_STUDY)
    spec = next(u for u in bp.fleet if u.role == "brick")
    with one_flight_at_a_time(), px4(tmp_path / "px4", instance=7) as url:
        # the defaults but the estimate wait (its EKF2 is ready within seconds; a loaded machine slows it)
        hw = hardware_config({"fc": url, "actuators": "sim", "camera": "sim"}, {"estimate_wait_s": 150})
        ports = select_adapters(sim=False, blueprint=bp, spec=spec, seed=0, camera="sim", faults=Faults(),
                                hardware=hw)  # fmt: skip
        try:
            assert ports.fc.autopilot == "px4"  # type: ignore[attr-defined]
            assert tuning_preset("ideal", ports) == "px4"
            # masonry flies its own velocity loop on it (acceleration setpoints once airborne), with its gains
            assert ports.fc.velocity_loop is not None  # type: ignore[attr-defined]
            assert fly_settings(hw, "ideal", ports) == uav_settings("px4", own_velocity_loop=True)
        finally:
            ports.close()
    err = capsys.readouterr().err
    assert "  [ok  ] tuning: control preset px4 (PX4 autopilot, from its HEARTBEAT)" in err.splitlines(), err
    assert "[ok  ] position estimate" in err and "-> ready to arm" in err


@pytest.mark.slow
def test_the_gates_velocity_on_the_real_px4_is_no_farther_from_the_truth_than_ekf2s(tmp_path: Path) -> None:
    """PX4's own hover: EKF2's velocity sits up to 0.5 m/s off the truth; the one the ``px4`` preset's gates read
    (consistent with the position, 2 s) is no farther from it, within a 40 s rms's spread (issue 29). On PX4's clock (SIH runs lock-step)."""
    tau_s = uav_settings("px4")["velocity_from_position_s"]
    flight = on_px4(tmp_path / "px4", 6, lambda url: hover(url, 40.0))
    kept = tmp_path / "hover.json"  # the flight, for a look at a failure
    kept.write_text(json.dumps({"estimate": flight.estimate, "truth": flight.truth}))
    assert len(flight.estimate) > 600 and len(flight.truth) > 600  # 30 Hz streams over 40 s
    ekf, filtered = velocity_errors(flight, tau_s)
    # measured in 14 hovers (2026-12-03/04; 8 of them beside 2-5 busy loops): EKF2 0.19-0.47 m/s, filtered
    # 0.09-0.53 m/s, the nearer in 13; once (a CI run, EKF2's worst hover, 0.47) 0.06 m/s farther. A 40 s rms varies
    # by about 0.1 m/s from hover to hover, so that is the margin. A hover barely moves: this checks that the filter
    # adds no error to what the gates read on the real PX4, not that it follows motion (tests/test_velocity_filter.py
    # checks that, deterministically, and the recorded hover's margin).
    assert filtered < ekf + 0.1, (ekf, filtered, str(kept))


#: How often (wall s) a flight's PX4 log is read for its SIH starved while the flight runs.
STARVED_POLL_S = 5.0


def _finish(proc: subprocess.Popen[str], wall_s: float, what: str, *px4_logs: Path) -> tuple[str, str]:
    """The process's output once it has ended, or a failure saying what did not end within ``wall_s``; ended at
    once (a failure) where one of its PX4s' logs (``px4_logs``: a mission's, each vehicle's) says its SIH starved
    (px4_sitl.sih_starved: a blind land follows, and masonry waited out the wall bound, 420 s, before on_px4 flew
    again; mission control watched only brick-1's PX4, and glue-1's starving ran out the mission's 720 s)."""
    deadline_s = time.monotonic() + wall_s
    while True:
        try:
            return proc.communicate(timeout=min(STARVED_POLL_S, max(0.0, deadline_s - time.monotonic())))
        except subprocess.TimeoutExpired:
            starved = [log for log in px4_logs if sih_starved(log.parent)]
            if not starved and time.monotonic() < deadline_s:
                continue
        proc.kill()
        _, err = proc.communicate()
        shown = starved[0] if starved else px4_logs[0]
        log = shown.read_text(errors="replace") if shown.is_file() else ""
        why = (
            f"its PX4's SIH starved ({SIH_STARVED!r}, {shown})"
            if starved
            else f"no result within {wall_s:g} s of wall time"
        )
        pytest.fail(f"{what}: {why}\n{err[-3000:]}\nPX4: {log[-1500:]}")


def _vehicle(proc: subprocess.Popen[str]) -> subprocess.Popen[str]:
    """A ``masonry`` process started in a session of its own, given the CPU share PX4 has (a vehicle's companion
    computer, a site's ground station: px4_sitl.give_the_cpu)."""
    give_the_cpu(proc.pid)
    return proc


def _latest_px4_log(folder: Path) -> Path:
    """The log of the PX4 flown last under ``folder`` (``px4``, or ``px4-2``, ``px4-3`` where px4_sitl.on_px4 flew
    again)."""
    logs = [f / "px4.log" for f in flight_folders(folder / "px4")]
    return next((log for log in reversed(logs) if log.is_file()), logs[0])


def _fly_task(folder: Path, url: str, uav: str, task: str, blueprint: str) -> dict:
    """``masonry fly --uav UAV --task TASK --blueprint BP --fc URL --actuators sim --camera sim`` with the issue's
    uav.yaml: its JSON result, asserted done."""
    config = folder / "uav.yaml"
    config.write_text(UAV_YAML)
    proc = _vehicle(masonry("fly", "--uav", uav, "--task", task, "--blueprint", blueprint, "--fc", url,
                            "--actuators", "sim", "--camera", "sim", "--config", str(config), "--format", "json",
                            own_session=True))  # fmt: skip
    px4_log_path = _latest_px4_log(folder)
    out, err = _finish(proc, TASK_WALL_S, f"masonry fly --task {task} on PX4 ({url})", px4_log_path)
    # the whole of it beside PX4's log, for a look at a failure
    (px4_log_path.parent / "fly.out").write_text(out)
    (px4_log_path.parent / "fly.err").write_text(err)
    results = [line for line in out.splitlines() if line.startswith("{")]
    assert results, f"no result (exit {proc.returncode}): {err[-3000:]}"
    result = dict(json.loads(results[-1]))
    px4_log = px4_log_path.read_text(errors="replace") if px4_log_path.is_file() else ""
    assert result["status"] == "done", (result.get("reason"), err[-2000:], px4_log[-1500:])
    assert TUNING_LINE in err
    return result


#: The scenario's and the adhesion task's PX4: EKF2's height on SIH's downward rangefinder (EKF2_HGT_REF 2, EKF2_RNG_CTRL
#: 2: SIH publishes one, 0-100 m, over its flat ground), not PX4 v1.16's defaults (GNSS, EKF2_HGT_REF 1; the range
#: finder conditional). On this loaded machine EKF2's height ran 0.5-1.8 m above SIH's truth within a flight on the
#: defaults, and A0's body, 0.65 m up to spray, stood on SIH's ground for 11-45 s while masonry read it 0.3-1.8 m up:
#: the spray pass could not move it (0 % in 27 s), the spray descent never arrived, the hover swung at 0.35 m/s rms
#: (benchmarks/bench_px4_spray.py). On the range finder the height stayed within -0.42..+0.60 m of the truth.
#: And the range finder described to EKF2 as SIH has it (issue 29, 2026-12-06): it reads 0 m on SIH's ground
#: (EKF2_MIN_RNG 0, "the range finder's reading on the ground"; 0.1 by default) and its ground reading, a float
#: hair below 0, is in its range (SIH_DISTSNSR_MIN -0.05; 0 by default). Without them PX4's land detector says
#: "Takeoff detected" 2-3 s before the airframe lifts (the thrust ramp), EKF2 in the air drops the out-of-range
#: range finder, its height drifts 0.2-0.3 m up on the barometer and GNSS, and at lift-off it restarts the range
#: finder with a height reset that takes the drift back: masonry's take-off saw no progress over its window and
#: stopped the climb ("take-off stalled at -0.06 m", 1 of 27 take-offs traced with benchmarks/bench_px4_takeoff.py;
#: 2 of 51 of A0's flights before). A setting of the simulated autopilot's estimator and simulator, not of masonry
#: (uav.yaml stays ``estimate_wait_s: 150``); a real spraying UAV needs its height above the surface within
#: centimetres as much, and its range finder valid on the ground (docs/hardware.md, "Autopilot parameters that
#: matter").
RANGE_FINDER_PX4_PARAMS = {
    "EKF2_HGT_REF": "2",
    "EKF2_RNG_CTRL": "2",
    "EKF2_MIN_RNG": "0",
    "SIH_DISTSNSR_MIN": "-0.05",
}


@pytest.mark.slow
def test_issue_29s_px4_scenario_places_brick_1_within_2_cm(tmp_path: Path) -> None:
    """The issue's scenario as written: a one-brick blueprint, ``masonry fly --uav brick --task B1 --fc
    udpin:0.0.0.0:14540+N --actuators sim --camera sim``, uav.yaml only ``estimate_wait_s: 150``, flown as PX4
    starts (as CI starts it: its first seconds' arming refusals are asked through), on a PX4 whose EKF2 holds its
    height on SIH's range finder (:data:`RANGE_FINDER_PX4_PARAMS`). On PX4's own defaults 20 of 24 beside a busy core
    (each failure EKF2's height and position running decimetres off the truth: docs/performance/autopilots.md, "The
    grasp and the descents on the real PX4 under load"); on the range finder 12 of 12, opt-in then for the take-off's
    stall on it, which the range finder described as SIH has it ends (issue 29, 2026-12-06: docs/performance/
    autopilots.md, "The take-off's stall on the range finder, traced"). Runs by default."""

    blueprint = tmp_path / "one_brick.yaml"
    blueprint.write_text(ONE_BRICK)

    def fly(url: str) -> dict:
        result = _fly_task(tmp_path, url, "brick", "B1", str(blueprint))
        assert result["placement_error_m"] is not None and result["placement_error_m"] < 0.02, result
        states = [e["state"] for e in result["trace"]]
        for state in ("takeoff", "pickup_align", "pickup_grasp", "place_align", "place_release", "land"):
            assert state in states
        return result

    result = on_px4(
        tmp_path / "px4", 6, fly, RANGE_FINDER_PX4_PARAMS
    )  # (again on a fresh PX4 if its sensors stopped)
    print(f"PX4: B1 placed {result['placement_error_m'] * 1000:.1f} mm off in {result['duration_s']} s")


@pytest.mark.slow
def test_an_adhesion_task_on_the_real_px4_covers_its_bead(tmp_path: Path) -> None:
    """A0 of the case study by glue-1 (its home is the vehicle's local origin), default settings, on a PX4 whose
    EKF2 holds its height on SIH's range finder (:data:`RANGE_FINDER_PX4_PARAMS`). On PX4's defaults every failure
    was EKF2's height running 0.5-1.8 m above the airframe, which then stood on SIH's ground below its spraying height
    (3 of 13 runs; benchmarks/bench_px4_spray.py); on the range finder with the ``px4`` preset's 45 s spray patience
    21 of 22 beside a busy core, the failure the take-off's stall on the range finder, which the range finder
    described as SIH has it ends (issue 29, 2026-12-06: docs/performance/autopilots.md, "The take-off's stall on the
    range finder, traced"). Runs by default."""

    def fly(url: str) -> dict:
        result = _fly_task(tmp_path, url, "adhesion", "A0", CASE_STUDY)
        assert result["coverage"] is not None and result["coverage"] >= 0.9, result
        return result

    result = on_px4(tmp_path / "px4", 7, fly, RANGE_FINDER_PX4_PARAMS)
    print(f"PX4: A0 coverage {result['coverage']:.0%} in {result['duration_s']} s")


#: The case study as a two-vehicle mission runs by default since branch px4case35 (2026-12-06: 5 of 5 in a row at load
#: average 2.7-7.1, makespans 197-307 s), as the scenario and A0 since branch rngtakeoff34. It was opt-in
#: (MASONRY_PX4_SITL_ALL=1) while its tower bricks' side look failed on the real PX4: the last leg's passes, flown on
#: the px4 model's 0.5 s feed-forward lag, ran 4-12 cm past the drop-off, and 20 looks back up took 85-100 s a descent
#: (main 4 of 5, the failure an as-built look 20.7 mm off after a release on a stale sighting; branch px4two31 4 of 5
#: the same way; docs/performance/autopilots.md, "The case study on two real PX4s"). The scenario and A0 were opt-in
#: until branch px4drop, and again until rngtakeoff34 (the take-off's stall on SIH's range finder); before that, issue
#: 29's list (branch px4real): EKF2 off SIH's truth by decimetres under load, which masonry flies and the simulated
#: world follows.

#: Wall seconds the two-vehicle mission may take: 285 s by hand (2026-12-03), pre-flights included.
MISSION_WALL_S = 720.0
#: PX4's simulated battery drains to its floor (SIM_BAT_MIN_PCT, 50 %) in a minute (SIM_BAT_DRAIN 60 s), and masonry
#: rightly retires a UAV at "battery low (51%)" after its first task: the mission's PX4s drain over an hour (the
#: simulator's parameter, not masonry's). Their EKF2 holds its height on SIH's range finder as the scenario's and
#: A0's (:data:`RANGE_FINDER_PX4_PARAMS`; on PX4's defaults until 2026-12-06, branch rngtakeoff34).
MISSION_PX4_PARAMS = {"SIM_BAT_DRAIN": "3600", **RANGE_FINDER_PX4_PARAMS}


@pytest.mark.slow
def test_the_case_study_as_a_mission_on_two_real_px4s(tmp_path: Path) -> None:
    """Mission control and two ``masonry fly --mission`` processes (brick-1 on PX4 instance 4, glue-1 on 5), all
    with default settings (the default reservation, ``site``; real time): the mission completes. Flown again
    on two fresh PX4s (twice at most) only where a failed one's PX4 logged its simulated sensors stopped (as
    px4_sitl.on_px4)."""
    px4_run_sh()  # skipped, with its reason, where the PX4 SITL is not configured
    folders = flight_folders(tmp_path / "mission")
    for folder in folders:
        try:
            print(_fly_the_case_study(folder))
            return
        except (AssertionError, pytest.fail.Exception):
            starved = [uav for uav in ("brick-1", "glue-1") if sih_starved(folder / uav)]
            if folder == folders[-1] or not starved:
                raise
            print(
                f"PX4: {', '.join(starved)}'s simulated sensors stopped ({SIH_STARVED!r}); the mission flown again"
            )


def _fly_the_case_study(folder: Path) -> str:
    """The mission flown and checked (the test's asserts); its summary line."""
    folder.mkdir(parents=True, exist_ok=True)
    config = folder / "uav.yaml"
    config.write_text(UAV_YAML)
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    name = ["--mission-name", f"px4-{endpoint.rsplit(':', 1)[1]}"]
    brick_dir, glue_dir = folder / "brick-1", folder / "glue-1"
    with (
        one_flight_at_a_time(),
        px4(brick_dir, instance=4, params=MISSION_PX4_PARAMS) as brick_url,
        px4(glue_dir, instance=5, params=MISSION_PX4_PARAMS) as glue_url,
    ):
        mc = _vehicle(masonry("mission-control", CASE_STUDY, "--listen", endpoint, "--format", "json",
                              "--verbose", *name, own_session=True))  # fmt: skip
        # each UAV with its log (tasks, states, poses: an MCAP file, docs/logging.md) for a look at a failure
        logs = [("--log", str(folder / f"{uav}.mcap")) for uav in ("brick-1", "glue-1")]
        uavs = [
            _vehicle(fly_mission(role, uav, url, endpoint, config, *name, *log, own_session=True))
            for (role, uav, url), log in zip(
                (("brick", "brick-1", brick_url), ("adhesion", "glue-1", glue_url)), logs, strict=True
            )
        ]
        with reaped([mc, *uavs]):
            mc_out, mc_err = _finish(mc, MISSION_WALL_S, "mission control (case study on two PX4s)",
                                     brick_dir / "px4.log", glue_dir / "px4.log")  # fmt: skip
            runs = [_finish(p, 120.0, f"masonry fly --mission ({uav})", px4_dir / "px4.log")
                    for p, uav, px4_dir in zip(uavs, ("brick-1", "glue-1"), (brick_dir, glue_dir))]  # fmt: skip
    for what, text in (
        ("mission-control", mc_err),
        *((uav, err) for uav, (_, err) in zip(("brick-1", "glue-1"), runs)),
    ):
        (folder / f"{what}.err").write_text(text)  # the whole of it, for a look at a failure
    for what, text in (("mission-control", mc_out), *zip(("brick-1", "glue-1"), (out for out, _ in runs))):
        (folder / f"{what}.out").write_text(text)  # the report, each UAV's tasks
    report, done = check_completed(mc, mc_out, mc_err, runs)
    ends = {tid: end for end, tid, _ in done}
    assert ends["A0"] < ends["B0"] and ends["A1"] < ends["B1"]  # each brick after its bead
    # the UAV's own: the release tick's horizontal error (masonry.fsm.dropoff_reach.resting_error_m); and where its
    # camera saw each brick rest as it climbed out (the as-built look), a measure of its own
    assert all(e < 0.02 for e in report["placement_error_m"].values()), report["placement_error_m"]
    assert all(p["deviation_m"] < 0.02 for p in report["as_built"].values()), report["as_built"]
    assert report["conflict_violations"] == 0 and report["dependency_violations"] == 0
    for p, (out, err) in zip(uavs, runs):
        assert p.returncode == 0, err[-2000:]
        assert json.loads(out)["mission_completed"]
        assert TUNING_LINE in err
    attempts = {t["id"]: t["attempts"] for t in report["tasks"]}
    retried = {t["id"]: t["attempts_detail"] for t in report["tasks"] if t["attempts"] > 1}
    errors = ", ".join(f"{k} {v * 1000:.1f} mm" for k, v in report["placement_error_m"].items())
    errors += " (as built " + ", ".join(
        f"{k} {p['deviation_m'] * 1000:.1f}" for k, p in report["as_built"].items()
    )
    errors += " mm)"
    return f"PX4: case study on two PX4s: makespan {report['makespan_s']} s; {errors}; attempts {attempts} {retried}"


#: PX4's geofence 1.5 m around home, its breach action 3 (PX4 v1.16 SIH went to AUTO.LOITER, a hold): the
#: one-brick scenario's pickup is 4.1 m out, so PX4's failsafe takes the vehicle out of OFFBOARD on the way there.
GEOFENCE_PX4_PARAMS = {"GF_MAX_HOR_DIST": "1.5", "GF_ACTION": "3"}


@pytest.mark.slow
def test_masonry_fly_ends_when_px4s_failsafe_takes_the_vehicle(tmp_path: Path) -> None:
    """A PX4 failsafe (its geofence) switches out of OFFBOARD mid-task: ``masonry fly`` stops, says which UAV and
    which mode in one line and exits 1 (it never returned before, issue 29). Instance 4; once more on a fresh PX4 if
    the first's SIH starved (px4_sitl.on_px4: seen at load average 10, baro and compass gone for good, a blind land,
    and no result within the wall bound)."""
    blueprint = tmp_path / "one_brick.yaml"
    blueprint.write_text(ONE_BRICK)
    config = tmp_path / "uav.yaml"
    config.write_text(UAV_YAML)

    def fly(url: str) -> str:
        proc = masonry("fly", "--uav", "brick", "--task", "B1", "--blueprint", str(blueprint), "--fc", url,
                        "--actuators", "sim", "--camera", "sim", "--config", str(config))  # fmt: skip
        out, err = _finish(proc, TASK_WALL_S, f"masonry fly on PX4 with a 1.5 m geofence ({url})",
                           _latest_px4_log(tmp_path))  # fmt: skip
        assert proc.returncode == 1, (out[-2000:], err[-2000:])
        *trace, line = out.strip().splitlines()
        assert (
            line.startswith("B1: failed in ") and ": brick-1: the autopilot took control: mode AUTO." in line
        ), out
        assert line.endswith(", not requested (masonry flies in OFFBOARD)"), line
        # the machine stopped (no LAND of its own over PX4's mode) and halted
        assert [s.split()[-1] for s in trace[-2:]] == ["emergency", "halted"], out
        return line

    print(f"PX4: {on_px4(tmp_path / 'px4', 4, fly, GEOFENCE_PX4_PARAMS)}")


#: Wall seconds `masonry fly --mission` may take to end once its PX4 is killed: the link watchdog (1 s), the landing
#: asked of a silent autopilot and the emergency's give-up (link_lost_timeout_s, 5 s), then 5 s of the link down
#: with the UAV halted (masonry.cli.fly_mission.AUTOPILOT_GONE_S); 15 s by hand (docs/performance/autopilots.md).
GONE_WALL_S = 60.0


@pytest.mark.slow
def test_masonry_fly_mission_ends_in_one_line_when_its_px4_dies(tmp_path: Path) -> None:
    """Issue 29: PX4's process killed (SIGKILL, its whole group) while ``masonry fly --mission`` flies issue 29's
    one-brick scenario: the UAV halts out of service, and the process ends within :data:`GONE_WALL_S` with one
    ``error:`` line naming its flight controller, exit 1 (it waited for mission control's silence before: 70 s, no
    word of why). Instance 5; mission control stays up (it would wait for the UAV). Flown again on a fresh PX4 where
    its simulated sensors stopped at the arming before the kill (:func:`px4_sitl.on_px4`, as every flight here: PX4's
    fault, not masonry's: in run 3 of ``bench_sitl_load.py --px4``, 2026-12-07, it failed the test at once)."""
    blueprint = tmp_path / "one_brick.yaml"
    blueprint.write_text(ONE_BRICK)
    config = tmp_path / "uav.yaml"
    config.write_text(UAV_YAML)

    def fly_then_kill(url: str) -> tuple[str, str, str, float]:
        endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
        name = ["--mission-name", f"px4-gone-{endpoint.rsplit(':', 1)[1]}"]
        mc = masonry("mission-control", str(blueprint), "--listen", endpoint, "--format", "json", *name)
        uav = _vehicle(masonry("fly", "--uav", "brick", "--name", "brick-1", "--blueprint", str(blueprint),
                               "--mission", endpoint, "--listen", f"tcp/127.0.0.1:{free_tcp_port()}", "--fc", url,
                               "--actuators", "sim", "--camera", "sim", "--config", str(config), "--format",
                               "json", *name, own_session=True))  # fmt: skip
        with reaped([mc, uav]):
            log = px4_log(url)
            deadline = time.monotonic() + TASK_WALL_S
            while "Takeoff detected" not in log.read_text(errors="replace"):  # PX4's own word: airborne
                px4_said = log.read_text(errors="replace")[-1500:]
                assert uav.poll() is None and time.monotonic() < deadline, (uav.returncode, px4_said)
                time.sleep(0.2)  # (PX4 runs in real time; its log is the only word of its take-off)
            kill_px4(url)
            killed_s = time.monotonic()
            out, err = _finish(uav, GONE_WALL_S, "masonry fly --mission after its PX4 was killed", log)
            ended_s = time.monotonic() - killed_s
        assert uav.returncode == 1, (out[-1500:], err[-2000:])
        return url, out, err, ended_s

    url, out, err, ended_s = on_px4(tmp_path / "px4", 5, fly_then_kill)
    last = err.strip().splitlines()[-1]
    said = f"error: brick-1: its flight controller ({url}) went silent and stayed so"
    assert last.startswith(said), err[-2000:]
    assert json.loads(out)["state"] == "halted", out[-1500:]
    print(f"PX4: masonry fly --mission ended {ended_s:.1f} s after its PX4 was killed: {last}")


#: More than PX4's COM_OF_LOSS_T (1.0 s in v1.16): setpoints this old no longer count as a stream.
STALE_S = 1.5


def _offboard_without_setpoints(url: str) -> None:
    fc = MavlinkFlightController(url, connect_timeout_s=60.0)
    try:
        fc.connect()
        fc.wait_for_estimate(150.0)
        fc.arm()  # through PX4's first-seconds refusals: a zero burst, OFFBOARD, the arming
        fc.disarm()  # the setpoint stream stops with it
        fc.clock.sleep(STALE_S)  # (longer under load: the setpoints only get older)
        fc.set_mode("OFFBOARD")  # disarmed: accepted without setpoints
        with pytest.raises(CommandRejected) as info:  # the arming in it is what PX4 refuses, as temporary
            fc.command("arm", MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        assert info.value.temporary, info.value.reason
        fc.arm()  # the client's own asking streams the burst again and arms
        assert fc.telemetry().mode == "OFFBOARD"
        fc.disarm()
    finally:
        fc.close()


@pytest.mark.slow
def test_px4s_offboard_without_setpoints_is_accepted_disarmed_and_its_arming_refused_as_temporary(
    tmp_path: Path,
) -> None:
    """Issue 29: what the project's SITL answers as (masonry.adapters.sitl_offboard): PX4 v1.16 enters OFFBOARD
    disarmed whatever the stream and refuses the arming in it as TEMPORARILY_REJECTED (never FAILED) until
    setpoints stream again, which :meth:`arm` asks through. Instance 5."""
    on_px4(tmp_path / "px4", 5, _offboard_without_setpoints)
