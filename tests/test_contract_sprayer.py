"""One Sprayer contract, run against the scripted fake, the simulator's sprayer and the Arduino adapter on its fake
firmware (a pseudo-terminal): the valve starts closed, reads back what it was told, accepts repeated commands.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from masonry.ports import Sprayer


def _fake_rig() -> Iterator[Sprayer]:
    from masonry.fakes import FakeClock, FakeSprayer

    yield FakeSprayer(FakeClock())


def _sim_rig() -> Iterator[Sprayer]:
    from test_sim_world import world

    yield world(seed=1).uavs["glue-1"].sprayer


def _arduino_rig() -> Iterator[Sprayer]:
    from masonry.adapters.arduino import ArduinoActuators
    from masonry.adapters.arduino_fake import FakeArduino

    with FakeArduino() as board, ArduinoActuators(board.port, boot_wait_s=0.05, timeout_s=0.5) as actuators:
        yield actuators


RIGS = {"fake": _fake_rig, "sim": _sim_rig, "arduino": _arduino_rig}


@pytest.fixture(params=sorted(RIGS))
def sprayer(request) -> Iterator[Sprayer]:
    yield from RIGS[request.param]()


def test_is_a_sprayer_and_starts_closed(sprayer: Sprayer) -> None:
    assert isinstance(sprayer, Sprayer)
    assert sprayer.is_valve_open() is False


def test_the_valve_reads_back_what_it_was_told(sprayer: Sprayer) -> None:
    sprayer.set_valve(True)
    assert sprayer.is_valve_open() is True
    sprayer.set_valve(False)
    assert sprayer.is_valve_open() is False


def test_repeated_commands_are_accepted(sprayer: Sprayer) -> None:
    for state in (True, True, False, False):
        sprayer.set_valve(state)
        assert sprayer.is_valve_open() is state
