"""The actuator line protocol (pure) and the serial adapter against the pseudo-terminal fake board."""

from __future__ import annotations

import os

import pytest
from hypothesis import given
from hypothesis import strategies as st

from masonry.actuator_protocol import (
    COMMANDS,
    ActuatorStatus,
    DeviceLogic,
    FrameError,
    Reply,
    Request,
    checksum,
    decode_reply,
    decode_request,
    encode_reply,
    encode_request,
    format_status,
    parse_status,
)
from masonry.adapters.arduino import ArduinoActuators
from masonry.adapters.arduino_fake import FakeArduino
from masonry.errors import CommandRejected, CommandTimeout, DeviceNotFound, LinkLost
from masonry.ports import Gripper, Sprayer
from waiting import SteppingClock, wait_until

requests = st.builds(
    Request,
    seq=st.integers(0, 255),
    command=st.sampled_from(sorted(COMMANDS)),
    args=st.lists(st.sampled_from(["ON", "OFF", "LOCK", "OPEN"]), max_size=2).map(tuple),
)


@given(requests)
def test_request_round_trip(request: Request) -> None:
    line = encode_request(request)
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    assert decode_request(line) == request


@given(request=requests, position=st.integers(0, 200), byte=st.integers(32, 126))
def test_a_corrupted_character_is_detected(request: Request, position: int, byte: int) -> None:
    original = encode_request(request)
    line = bytearray(original)
    i = position % (len(line) - 1)
    line[i] = byte
    if bytes(line).upper() == original.upper():
        return  # the same line (checksum digits are case-insensitive)
    with pytest.raises(FrameError):  # one substituted character always changes the XOR (or the shape)
        decode_request(bytes(line))


@given(st.builds(ActuatorStatus, st.booleans(), st.booleans(), st.booleans(), st.booleans()))
def test_status_round_trip(status: ActuatorStatus) -> None:
    reply = decode_reply(encode_reply(Reply(7, True, format_status(status))))
    assert reply.seq == 7 and parse_status(reply.fields) == status


def test_replies_and_errors_decode() -> None:
    assert decode_reply(b"12 OK*" + checksum("12 OK").encode() + b"\r\n") == Reply(12, True)
    err = decode_reply(encode_reply(Reply(3, False, code="FAULT", message="valve servo stalled")))
    assert (err.ok, err.code, err.message) == (False, "FAULT", "valve servo stalled")
    hello = decode_reply(b"HELLO masonry-actuators 1*" + checksum("HELLO masonry-actuators 1").encode())
    assert hello.hello and hello.fields == ("masonry-actuators", "1")
    for bad in (b"", b"garbage\n", b"1 OK*00\n", b"\xff\xfe*00\n", b"999 OK*" + checksum("999 OK").encode()):
        with pytest.raises(FrameError):
            decode_reply(bad)
    with pytest.raises(FrameError, match="joint"):
        parse_status(("mag=1", "joint=MAYBE", "valve=OPEN", "attached=0"))


def test_device_logic_acts_once_per_sequence_number() -> None:
    device = DeviceLogic()
    line = encode_request(Request(5, "MAG", ("ON",)))
    first = device.handle(line)
    assert device.handle(line) == first  # a retry
    assert len(device.executed) == 1 and device.status.magnet_on
    assert decode_reply(device.handle(encode_request(Request(6, "MAG", ("MAYBE",))))).code == "BADARG"
    assert decode_reply(device.handle(encode_request(Request(7, "FLY", ())))).code == "UNKNOWN"
    assert decode_reply(device.handle(b"8 MAG ON*00\n")).code == "BADCHK"
    assert decode_reply(device.handle(b"\x00\x01junk\n")).code == "BADLINE"


@pytest.fixture()
def fake():
    board = FakeArduino()
    board.start()
    yield board
    board.stop()


def open_board(port: str, **options) -> ArduinoActuators:
    options.setdefault("boot_wait_s", 0.05)
    options.setdefault("timeout_s", 0.1)
    board = ArduinoActuators(port, **options)
    board.connect()
    return board


def test_every_command(fake: FakeArduino) -> None:
    with open_board(fake.port) as act:
        assert isinstance(act, Gripper) and isinstance(act, Sprayer)
        assert act.version == 1
        assert act.status() == ActuatorStatus(
            magnet_on=False, joint_locked=True, valve_open=False, attached=False
        )
        act.set_joint_locked(False)
        act.set_magnet(True)
        assert not act.is_attached()
        fake.logic.set_attached(True)  # the brick sensor in the conical guide closes
        assert act.is_attached()
        act.set_valve(True)
        assert act.is_valve_open()
        assert act.status() == ActuatorStatus(
            magnet_on=True, joint_locked=False, valve_open=True, attached=True
        )
        act.set_valve(False)
        act.set_joint_locked(True)
        act.set_magnet(False)
        assert act.status() == ActuatorStatus(
            magnet_on=False, joint_locked=True, valve_open=False, attached=False
        )
        assert act.ping() == ("masonry-actuators", "1")
        assert [r.command for r in fake.logic.executed].count("MAG") == 2


def test_an_error_reply_is_a_rejection_with_the_reason(fake: FakeArduino) -> None:
    fake.logic.faults["VALVE"] = "valve servo stalled"
    with open_board(fake.port) as act:
        with pytest.raises(CommandRejected) as info:
            act.set_valve(True)
        assert info.value.command == f"VALVE OPEN on {fake.port}"
        assert info.value.reason == "FAULT valve servo stalled"


def test_silence_times_out_after_the_retries(fake: FakeArduino) -> None:
    clock = SteppingClock(0.01)
    with open_board(fake.port, retries=2, monotonic=clock) as act:
        fake.silent = True
        started_s = clock.now_s
        with pytest.raises(
            CommandTimeout, match=rf"{fake.port}: actuator board did not answer MAG ON \(3 tries of 0\.10 s"
        ):
            act.set_magnet(True)
        # three tries of 0.1 s on the adapter's clock, each ending within a few polls of its deadline
        assert 3 * 0.1 <= clock.now_s - started_s <= 3 * (0.1 + 4 * 0.01)
        wait_until(lambda: len([r for r in fake.received if b"MAG ON" in r]) >= 3, 5.0, "the three tries")
        assert len([r for r in fake.received if b"MAG ON" in r]) == 3


def test_a_lost_request_is_retried_and_acted_on_once(fake: FakeArduino) -> None:
    with open_board(fake.port) as act:
        fake.drop_requests = 1
        act.set_magnet(True)
        assert len([r for r in fake.received if b"MAG ON" in r]) == 2
        assert [r.command for r in fake.logic.executed].count("MAG") == 1
        assert fake.logic.status.magnet_on


def test_garbage_on_the_line_is_ignored(fake: FakeArduino) -> None:
    with open_board(fake.port) as act:
        fake.inject(b"\x00\xff\xfe noise\n")
        fake.inject(b"half a li")  # completed by the next reply's bytes: one bad line, then good ones
        fake.inject(b"\n3 OK*00\n")  # bad checksum
        fake.inject(encode_reply(Reply(200, True)))  # a well-formed answer to nobody
        act.set_valve(True)
        assert act.is_valve_open()
        assert act.garbage_lines >= 3


def test_garbage_sent_to_the_board_gets_an_error_not_an_action(fake: FakeArduino) -> None:
    with open_board(fake.port) as act:
        os.write(os.open(fake.port, os.O_WRONLY | os.O_NOCTTY), b"MAG ON please\n")  # another writer
        wait_until(lambda: b"MAG ON please\n" in fake.received, 5.0, "the board to read the stray line")
        assert act.status().magnet_on is False


def test_a_board_reset_is_noticed_and_the_command_resent(fake: FakeArduino) -> None:
    with open_board(fake.port) as act:
        act.set_magnet(True)
        fake.silent = True
        fake.reset()  # HELLO arrives while we wait
        fake.silent = False
        fake.drop_requests = 1  # the request sent during the reboot is lost
        act.set_joint_locked(False)
        assert act.resets_seen >= 1
        assert fake.logic.status.joint_locked is False


def test_unplugged_while_in_use(fake: FakeArduino) -> None:
    act = open_board(fake.port)
    fake.unplug()
    with pytest.raises(LinkLost, match=f"{fake.port}: actuator board unplugged"):
        for _ in range(3):  # the first write may still land in the kernel buffer
            act.is_attached()
    assert not act.connected


def test_missing_port_names_it() -> None:
    with pytest.raises(DeviceNotFound, match="/dev/ttyMASONRY9: cannot open"):
        ArduinoActuators("/dev/ttyMASONRY9").connect()


def test_wrong_device_names_the_port(fake: FakeArduino) -> None:
    fake.wrong_device = True
    with pytest.raises(DeviceNotFound, match=f"{fake.port}: no masonry-actuators device answered"):
        open_board(fake.port)


def test_a_silent_device_is_not_found(fake: FakeArduino) -> None:
    fake.silent = True
    clock = SteppingClock(0.01)
    started_s = clock.now_s
    with pytest.raises(DeviceNotFound, match=r"wrong port or firmware.*3 tries of 0\.10 s"):
        open_board(fake.port, monotonic=clock)
    # the boot wait (0.05 s) and three PINGs of 0.1 s on the adapter's clock: it gives up then, not later
    assert 0.05 + 3 * 0.1 <= clock.now_s - started_s <= 0.05 + 3 * 0.1 + 4 * 4 * 0.01


def test_loopback_url_is_not_a_board() -> None:
    # pyserial's loop:// echoes our own requests back: they are not replies
    with pytest.raises(DeviceNotFound, match="loop://"):
        open_board("loop://")
