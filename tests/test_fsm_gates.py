"""The gate states' exit checks as data (masonry.fsm.gates): declared, drawn, pure, and one declaration to add."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from fsm_rig import Rig
from masonry.fsm import UavConfig
from masonry.fsm.attempt import Swing
from masonry.fsm.diagram import machine_graph, watchdog_lines
from masonry.fsm.gates import ADHESION_GATES, BRICK_GATES, Gate, Gated, swing_gate
from masonry.ports import Telemetry

CFG = UavConfig("brick-1", "brick", (0.0, 0.0, 0.0))


@dataclass(frozen=True)
class View:
    """A gated UAV as the checks read it."""

    config: UavConfig
    swing: Swing
    leg_end_s: float
    hold_target_m: np.ndarray


def _tel(position_m: tuple[float, float, float]) -> Telemetry:
    return Telemetry(
        0.0, position_m, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), True, "GUIDED", 0.9, True, True, False
    )


def test_the_swing_gate_fails_only_past_its_patience_and_says_how_far_off() -> None:
    fast = (2.0 * CFG.swing_speed_mps) ** 2
    near = View(CFG, Swing(0.0, 10.0, fast), 5.0, np.array([0.0, 0.0, 1.0]))
    view: Gated = near
    assert swing_gate(5.0 + CFG.swing_patience_s - 0.1, _tel((0.0, 0.0, 1.0)), view) is None
    reason = swing_gate(5.0 + CFG.swing_patience_s, _tel((0.3, 0.0, 1.0)), view)
    assert reason is not None and reason.startswith(
        f"swinging at {2.0 * CFG.swing_speed_mps:.2f} m/s rms, 0.30 m off"
    )
    assert "position loop is too fast" in reason
    blown = swing_gate(5.0 + CFG.swing_patience_s, _tel((3.0, 0.0, 1.0)), view)
    assert blown is not None and blown.endswith("blown off by gusts beyond what the autopilot holds against")
    calm = View(CFG, Swing(0.0, 10.0, (0.5 * CFG.swing_speed_mps) ** 2), 5.0, np.array([0.0, 0.0, 1.0]))
    assert swing_gate(100.0, _tel((0.3, 0.0, 1.0)), calm) is None


def test_the_machines_declare_the_swing_gate_on_their_gate_states() -> None:
    assert [(g.name, g.states) for g in BRICK_GATES] == [("swing", ("pickup_align", "place_align"))]
    assert [(g.name, g.states) for g in ADHESION_GATES] == [("swing", ("hover",))]
    assert Rig("brick").uav.gates == BRICK_GATES and Rig("adhesion").uav.gates == ADHESION_GATES


@pytest.mark.parametrize(
    ("kind", "line"), [("brick", "gate swing: pickup_align, place_align"), ("adhesion", "gate swing: hover")]
)
def test_the_diagram_draws_the_gates_after_the_watchdogs(kind: str, line: str) -> None:
    lines = watchdog_lines(kind)
    assert lines[-1] == line and lines[-2].startswith("gates (")
    assert line in machine_graph(kind).source


def test_a_new_gate_is_one_declaration() -> None:
    """A gate that fails the alignment while the brick looks too close to the camera's edge (here: always)."""
    rig = Rig("brick")
    rig.uav.gates = (
        *rig.uav.gates,
        Gate("edge", ("pickup_align",), lambda now_s, tel, g: "brick at the edge"),
    )
    rig.run()
    result = rig.link.results[0]
    assert result.status == "failed" and result.reason == "could not align above brick 7: brick at the edge"
    assert rig.followed("pickup_align", "failsafe")


def test_the_default_gates_let_a_calm_task_through() -> None:
    rig = Rig("brick").run()
    assert rig.link.results[0].status == "done"
    assert rig.followed("pickup_align", "pickup_descend") and rig.followed("place_align", "place_descend")


@pytest.mark.parametrize(("kind", "mean_sq_mps2"), [("brick", 0.09), ("adhesion", 0.34)])
def test_the_swing_gate_counts_the_axes_its_states_judge(kind: str, mean_sq_mps2: float) -> None:
    """Issue 29: the brick UAV's alignments judge the horizontal, so its swing counts the horizontal speed (PX4's
    hover wanders vertically); the adhesion UAV's hover asks the nozzle still in all three axes, and counts them."""
    uav = Rig(kind).uav
    tel = Telemetry(
        0.0, (0.0, 0.0, 1.0), (0.3, 0.0, 0.5), (0.0, 0.0, 0.0), True, "GUIDED", 0.9, True, True, False
    )
    for tick in range(200):  # 10 s, five swing windows: the mean has settled on the speed's square
        uav._now_s = 0.05 * tick
        assert uav._gate_failure(tel) is None  # idle: no gate guards it
    assert uav.swing.mean_sq_mps2 == pytest.approx(mean_sq_mps2, rel=0.01)  # (1 - 1/40) ** 199 of it left
