"""masonry.fsm.tool: a tool's body target puts it on its target; its distance is the numpy one."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from masonry.airframe import DEFAULT_AIRFRAME
from masonry.fsm.tool import Tool
from masonry.ports import Telemetry

coords = st.floats(-5.0, 5.0)


def _tel(position, yaw_rad, roll_rad=0.0, pitch_rad=0.0) -> Telemetry:
    return Telemetry(
        0.0,
        tuple(position),
        (0.0, 0.0, 0.0),
        (roll_rad, pitch_rad, yaw_rad),
        True,
        "GUIDED",
        1.0,
        True,
        True,
        False,
    )


@given(st.tuples(coords, coords, coords), st.floats(-3.2, 3.2))
def test_the_body_target_puts_the_tool_on_its_target(target, yaw_rad) -> None:
    effector = Tool.at(DEFAULT_AIRFRAME.effector_offset_m)
    body = effector.body_target(target, yaw_rad)
    tel = _tel(body.tolist(), yaw_rad)
    assert effector.position(tel).tolist() == pytest.approx(list(target), abs=1e-12)
    assert effector.distance_m(tel, np.array(target)) == pytest.approx(0.0, abs=1e-12)


def test_a_tilted_body_moves_its_tool() -> None:
    tool = Tool.at([0.0, 0.0, -0.3])
    level, tilted = _tel((0.0, 0.0, 1.0), 0.0), _tel((0.0, 0.0, 1.0), 0.0, roll_rad=0.2)
    assert tool.position(level).tolist() == pytest.approx([0.0, 0.0, 0.7])
    assert tool.distance_m(tilted, (0.0, 0.0, 0.7)) == pytest.approx(2 * 0.3 * np.sin(0.1), rel=1e-12)
