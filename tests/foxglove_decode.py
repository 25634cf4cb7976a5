"""Decode Foxglove's messages with the schema that came with them (a protobuf ``FileDescriptorSet``, as the
Foxglove SDK writes it into an MCAP file or advertises it on its WebSocket server): Foxglove's own definitions,
not masonry's."""

from __future__ import annotations

from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.json_format import MessageToDict
from google.protobuf.message import DecodeError

_CLASSES: dict[tuple[str, bytes], Any] = {}


def message_class(name: str, file_descriptor_set: bytes) -> Any:
    """The protobuf class of message ``name`` (``foxglove.SceneUpdate``) built from its schema's bytes."""
    key = (name, bytes(file_descriptor_set))
    if key not in _CLASSES:
        fds = descriptor_pb2.FileDescriptorSet.FromString(key[1])
        pool = descriptor_pool.DescriptorPool()
        pending = list(fds.file)
        while pending:  # dependencies first, whatever the set's order
            added = [f for f in pending if all(_has(pool, d) for d in f.dependency)]
            assert added, f"{name}: the schema's files depend on files it does not hold"
            for f in added:
                pool.Add(f)
            pending = [f for f in pending if f not in added]
        _CLASSES[key] = message_factory.GetMessageClass(pool.FindMessageTypeByName(name))
    return _CLASSES[key]


def _has(pool: Any, file_name: str) -> bool:
    try:
        pool.FindFileByName(file_name)
    except KeyError:
        return False
    return True


def decode(name: str, file_descriptor_set: bytes, data: bytes) -> dict[str, Any]:
    """``data`` decoded as ``name``; it must be exactly that message (re-encoded, the same bytes: no unknown or
    malformed field)."""
    cls = message_class(name, file_descriptor_set)
    try:
        msg = cls.FromString(data)
    except DecodeError as exc:
        raise AssertionError(f"{name}: not a well-formed {name} ({exc})") from None
    assert msg.SerializeToString(deterministic=True) == bytes(data), f"{name}: not a well-formed {name}"
    return MessageToDict(msg, preserving_proto_field_name=True, always_print_fields_with_no_presence=True)
