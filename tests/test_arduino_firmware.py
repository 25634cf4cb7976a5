"""The Arduino sketch speaks the same protocol as the Python reference: compiled for the host with a small shim
(firmware/host_shim), fed the same lines as ``DeviceLogic``, its answers must match (codes, fields, sequence)."""

from __future__ import annotations

import random
import shutil
import subprocess
from pathlib import Path

import pytest

from masonry.actuator_protocol import DeviceLogic, Request, decode_reply, encode_request

ROOT = Path(__file__).resolve().parents[1]
SKETCH = ROOT / "firmware" / "masonry_actuators" / "masonry_actuators.ino"
SHIM = ROOT / "firmware" / "host_shim"


@pytest.fixture(scope="module")
def firmware(tmp_path_factory) -> Path:
    compiler = shutil.which("g++")
    if compiler is None:
        pytest.skip("g++ is not installed: the sketch cannot be compiled for the host")
    binary = tmp_path_factory.mktemp("fw") / "masonry_actuators"
    cmd = [
        compiler, "-std=c++17", "-Wall", "-Wextra", "-Werror", f"-I{SHIM}", "-x", "c++", "-include", "Arduino.h",
        str(SKETCH), "-x", "none", str(SHIM / "shim.cpp"), "-o", str(binary),
    ]  # fmt: skip
    subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=120)
    return binary


def run(binary: Path, lines: list[bytes], attached: bool = False) -> tuple[list[bytes], str]:
    out = subprocess.run(
        [str(binary)],
        input=b"".join(lines),
        capture_output=True,
        timeout=20,
        check=False,
        env={"MASONRY_SHIM_ATTACHED": "1" if attached else "0"},
    )
    assert out.returncode == 0
    return out.stdout.splitlines(keepends=True), out.stderr.decode()


def summary(line: bytes) -> tuple:
    reply = decode_reply(line)  # also checks the firmware's checksum
    return (reply.hello, reply.seq, reply.ok, reply.code, reply.fields)


def conversation() -> list[bytes]:
    rng = random.Random(6)
    lines = [
        encode_request(Request(1, "PING")),
        encode_request(Request(1, "PING")),  # a retry
        encode_request(Request(2, "MAG", ("ON",))),
        encode_request(Request(3, "STATUS")),
        b"4 mag off*" + format(_xor(b"4 mag off"), "02x").encode() + b"\n",  # lower case, lower-case checksum
        encode_request(Request(5, "JOINT", ("SIDEWAYS",))),
        encode_request(Request(6, "VALVE", ("OPEN", "WIDE"))),
        encode_request(Request(7, "FLY")),
        encode_request(Request(8, "STATUS", ("NOW",))),
        b"9 VALVE OPEN*00\n",  # bad checksum
        b"no checksum at all\n",
        b"x9 PING*" + format(_xor(b"x9 PING"), "02X").encode() + b"\n",  # bad sequence number
    ]
    commands = [("MAG", "ON"), ("MAG", "OFF"), ("JOINT", "LOCK"), ("JOINT", "UNLOCK"), ("VALVE", "OPEN"),
                ("VALVE", "CLOSE"), ("STATUS", None), ("PING", None)]  # fmt: skip
    seq = 10
    for _ in range(150):
        command, arg = rng.choice(commands)
        if rng.random() > 0.2:  # otherwise a retry of the previous sequence number
            seq = (seq + 1) % 256
        lines.append(encode_request(Request(seq, command, (arg,) if arg else ())))
    return lines


def _xor(data: bytes) -> int:
    value = 0
    for byte in data:
        value ^= byte
    return value


@pytest.mark.parametrize("attached", [False, True])
def test_firmware_answers_like_the_reference(firmware: Path, attached: bool) -> None:
    lines = conversation()
    got, pins = run(firmware, lines, attached)
    reference = DeviceLogic(
        release_drops_brick=False
    )  # the test holds the sensor pin, as the firmware reads it
    reference.set_attached(attached)
    expected = [reference.hello()] + [reference.handle(line) for line in lines]
    assert len(got) == len(expected)
    for sent, mine, theirs in zip([b"<boot>", *lines], got, expected):
        assert summary(mine) == summary(theirs), f"after {sent!r}: firmware {mine!r}, reference {theirs!r}"
    assert "SERVO 9 20" in pins and "SERVO 10 0" in pins  # joint locked, valve closed at boot
    assert "PIN 7 1" in pins  # the magnet was switched on at some point
