"""The brick UAV's descents start from rest on a noisy position source (issue 29, ``BrickUav._descent_from_rest``).

On the real PX4 v1.16 SITL the hover at the end of an alignment swings 4-5 cm at up to 0.14 m/s; a 7 s
minimum-jerk descent started with that tick's velocity swung 15-25 cm off its drop-off and left the UAV crossing the
1.5 cm disc ("drop-off of B1 not reached within 1.5 cm after 3 descents"; docs/performance/autopilots.md).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import pyramid
from masonry.fsm.adhesion import AdhesionUav
from masonry.fsm.brick import BrickUav
from masonry.fsm.config import UavConfig
from masonry.mission.simulate import SimulatedMission
from masonry.motion import MinJerk

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def _descents(monkeypatch: pytest.MonkeyPatch, vehicle: str) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """A simulated pyramid of three on ``vehicle``: per descent (pickup and drop-off), the UAV's velocity as it
    began, the leg's starting velocity and how far (m) its reference strays horizontally from the straight line
    between its ends."""
    seen: list[tuple[np.ndarray, np.ndarray, float]] = []

    def record(entered):  # type: ignore[no-untyped-def]
        def enter(self: BrickUav, *args: object, **kwargs: object) -> None:
            entered(self, *args, **kwargs)
            assert self._tel is not None and self.nav.traj is not None
            traj, shift = self.nav.traj, np.asarray(self.nav._shift_m or (0.0, 0.0, 0.0))
            start = np.asarray(traj.sample_floats(0.0)[0]) + shift
            end = np.asarray(traj.sample_floats(traj.duration_s)[0]) + shift
            line = (end - start)[:2]
            stray = 0.0
            for i in range(51):
                ref = np.asarray(traj.sample_floats(traj.duration_s * i / 50)[0]) + shift
                d = (ref - start)[:2]
                along = float(np.dot(d, line) / max(float(np.dot(line, line)), 1e-12))
                stray = max(stray, float(np.linalg.norm(d - min(1.0, max(0.0, along)) * line)))
            v0 = np.asarray(traj.sample_floats(0.0)[1])
            seen.append((np.asarray(self._tel.velocity_mps, dtype=float), v0, stray))

        return enter

    monkeypatch.setattr(BrickUav, "enter_pickup_descend", record(BrickUav.enter_pickup_descend))
    monkeypatch.setattr(BrickUav, "enter_place_descend", record(BrickUav.enter_place_descend))
    mission = SimulatedMission.from_blueprint(pyramid(2, clearance_m=1.0), seed=0, vehicle=vehicle)
    assert mission.run().completed
    return seen


def test_on_the_px4_preset_every_descent_starts_from_rest_and_keeps_to_its_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    descents = _descents(monkeypatch, "px4")
    assert len(descents) >= 6  # three bricks: a pickup and a drop-off each
    assert any(math.hypot(v[0], v[1]) > 0.01 for v, _, _ in descents)  # the wander's velocity at the gate ...
    for _, v0, stray in descents:
        assert np.allclose(v0, 0.0)  # ... not carried into the leg
        # the leg stays on the straight line (a few mm of the side look's shift aside; the old leg: 0.2 v0 T)
        assert stray <= 0.002, stray


def test_on_the_px4_preset_the_spray_descents_start_from_rest_too(monkeypatch: pytest.MonkeyPatch) -> None:
    # A0 on the real PX4 (issue 29): the hover's gate passed at 0.15 m/s of the wander and the 2.7 s spray descent's
    # reference strayed 8 cm off its line; from rest it keeps to it
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    entered = AdhesionUav.enter_descend

    def enter(self: AdhesionUav, *args: object, **kwargs: object) -> None:
        entered(self, *args, **kwargs)
        assert self._tel is not None and self.nav.traj is not None
        seen.append(
            (np.asarray(self._tel.velocity_mps, dtype=float), np.asarray(self.nav.traj.sample_floats(0.0)[1]))
        )

    monkeypatch.setattr(AdhesionUav, "enter_descend", enter)
    mission = SimulatedMission.from_blueprint(load_blueprint(CASE_STUDY), seed=0, vehicle="px4")
    assert mission.run().completed
    assert len(seen) >= 2  # A0 and A1
    assert any(np.linalg.norm(v) > 0.01 for v, _ in seen)  # the wander's velocity at the gate ...
    assert all(np.allclose(v0, 0.0) for _, v0 in seen)  # ... not carried into the leg


def test_without_a_gate_window_the_descent_starts_from_the_uavs_state_as_before(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert UavConfig(name="b", role="brick", home_m=(0.0, 0.0, 0.0)).gate_window_s == 0.0  # ideal, arducopter
    descents = _descents(monkeypatch, "arducopter")
    for v, v0, _ in descents:
        assert np.allclose(v0, v)


def test_a_minimum_jerk_leg_carries_its_starting_velocity_out_to_a_fifth_of_v0_t() -> None:
    # the old descent on the real PX4: 0.14 m/s at the gate, 7 s down: 19 cm to the side at its farthest
    leg = MinJerk(
        np.zeros(3), np.array([0.14, 0.0, 0.0]), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), 7.0
    )
    farthest = max(leg.sample_floats(7.0 * i / 100)[0][0] for i in range(101))
    assert farthest == pytest.approx(0.197 * 0.14 * 7.0, rel=0.02)
