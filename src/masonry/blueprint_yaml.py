"""A fast and guarded YAML reader for blueprints: libyaml's event stream, built into Python data without PyYAML's
pure-Python composer, resolver and constructor (5-8x faster on a 20,000-brick wall).

The result equals ``yaml.safe_load`` for every document, except in three ways that protect a blueprint
(docs/blueprint-format.md, "Limits"):

- a key given twice in one mapping is an error naming both lines (``yaml.safe_load`` keeps the last value);
- numbers in exponent form without a dot or a sign (``5e-2``, ``1e9``) are floats, as in YAML 1.2 and JSON
  (YAML 1.1 reads them as strings);
- aliases may not expand the document by more than :data:`MAX_ALIAS_EXPANSION_NODES` nodes, and an alias may
  not refer to a node that contains it (a "billion laughs" document is one line of error, not gigabytes).

Plain numbers, booleans and nulls take a fast path; any other plain scalar goes through PyYAML's own resolver and
constructor; a document using anchors, aliases, merge keys or explicit tags is handed to PyYAML whole (with the
same three rules). :func:`read_text_limited` reads a file for it: a regular file of at most
:data:`MAX_FILE_BYTES`, so ``/dev/zero`` or a FIFO is refused instead of filling memory or hanging.
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml

#: A blueprint or UAV settings file larger than this is refused before it is read (a 20,000-brick wall is ~2 MB).
MAX_FILE_BYTES = 64 * 1024 * 1024
#: How many nodes aliases may add to a document beyond the ones written in it (anchors are for sharing a size or
#: a pickup, not for building walls; a billion-laughs document needs ~10^9).
MAX_ALIAS_EXPANSION_NODES = 100_000

_BASE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_INT = re.compile(r"-?(?:0|[1-9][0-9]*)\Z").match
_FLOAT = re.compile(r"-?[0-9]+\.[0-9]+\Z").match
#: YAML 1.2 core-schema floats in exponent form that YAML 1.1 leaves as strings (no dot, or an unsigned exponent).
_EXP_FLOAT_TEXT = r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)[eE][-+]?[0-9]+\Z"
_EXP_FLOAT = re.compile(_EXP_FLOAT_TEXT).match
_CONSTANTS: dict[str, Any] = {"true": True, "false": False, "null": None, "~": None, "": None}
_MERGE = "tag:yaml.org,2002:merge"


class YamlLimitError(yaml.MarkedYAMLError):
    """A document breaks one of this reader's rules (duplicate key, alias expansion); ``problem_mark`` says where."""

    def __init__(self, problem: str, mark: Any = None) -> None:
        super().__init__(problem=problem, problem_mark=mark)


class FileLimitError(Exception):
    """A file is not a regular file, or is larger than :data:`MAX_FILE_BYTES`; the message says which."""


def read_text_limited(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of a regular file of at most ``max_bytes`` bytes.

    Raises:
        FileLimitError: a FIFO, device or socket (``/dev/zero``, a pipe), or a file over ``max_bytes``.
        OSError: the file cannot be opened or read (FileNotFoundError, IsADirectoryError, PermissionError...).
        UnicodeDecodeError: the bytes are not UTF-8 (a binary file).
    """
    # O_NONBLOCK: opening a FIFO with no writer must not hang before fstat can tell what it is.
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    with os.fdopen(fd, "rb") as f:
        info = os.fstat(fd)
        if stat.S_ISDIR(info.st_mode):
            raise IsADirectoryError(21, "Is a directory", str(path))
        if not stat.S_ISREG(info.st_mode):
            raise FileLimitError("not a regular file (a device, pipe or socket); give a file")
        if info.st_size > max_bytes:
            raise FileLimitError(f"file is {_mb(info.st_size)}, over the {_mb(max_bytes)} limit")
        os.set_blocking(fd, True)
        data = f.read(max_bytes + 1)  # the file may grow after fstat
    if len(data) > max_bytes:
        raise FileLimitError(f"file is over the {_mb(max_bytes)} limit")
    return data.decode("utf-8")


def _mb(n_bytes: int) -> str:
    return f"{n_bytes / (1024 * 1024):.0f} MB" if n_bytes >= 1024 * 1024 else f"{n_bytes} bytes"


class GuardedLoader(_BASE_LOADER):  # type: ignore[misc, valid-type]
    """PyYAML's safe loader with this module's rules: duplicate keys, YAML 1.2 exponent floats, alias expansion."""

    def construct_document(self, node: Any) -> Any:
        _check_expansion(node)
        return super().construct_document(node)

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            _check_duplicates(self, node)
        return super().construct_mapping(node, deep=deep)


GuardedLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(_EXP_FLOAT_TEXT), list("-+.0123456789")
)


def _check_duplicates(loader: Any, node: Any) -> None:
    """Explicit keys of one mapping must differ (merged keys ``<<`` may be overridden: that is their purpose)."""
    seen: dict[Any, Any] = {}
    for key_node, _ in node.value:
        if key_node.tag == _MERGE or not isinstance(key_node, yaml.ScalarNode):
            continue
        key = loader.construct_object(key_node)
        try:
            first: Any = seen.setdefault(key, key_node.start_mark)
        except TypeError:
            continue  # an unhashable key: the constructor reports it
        if first is not key_node.start_mark:
            raise YamlLimitError(_duplicate(key, first.line + 1), key_node.start_mark)


def _duplicate(key: Any, first_line: int) -> str:
    from masonry.blueprint import quote

    return f"duplicate key {quote(key)} (first given on line {first_line})"


def _check_expansion(root: Any) -> None:
    """Refuse recursive aliases and documents whose aliases add more than MAX_ALIAS_EXPANSION_NODES nodes."""
    size: dict[int, int] = {}
    open_nodes: set[int] = set()
    stack: list[tuple[Any, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            open_nodes.discard(key)
            children = _children(node)
            size[key] = 1 + sum(size[id(c)] for c in children)
            continue
        if key in size:
            continue
        if key in open_nodes:
            raise YamlLimitError("recursive alias (a node that contains itself)", node.start_mark)
        open_nodes.add(key)
        stack.append((node, True))
        for child in _children(node):
            if id(child) in open_nodes:
                raise YamlLimitError("recursive alias (a node that contains itself)", child.start_mark)
            if id(child) not in size:
                stack.append((child, False))
    expanded, written = size[id(root)], len(size)
    if expanded - written > MAX_ALIAS_EXPANSION_NODES:
        raise YamlLimitError(
            f"aliases expand the document to {expanded} nodes from {written} written "
            f"(at most {MAX_ALIAS_EXPANSION_NODES} more allowed)",
            root.start_mark,
        )


def _children(node: Any) -> list[Any]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def _plain(value: str) -> Any:
    if _FLOAT(value):
        return float(value)
    if _INT(value):
        return int(value)
    if value in _CONSTANTS:
        return _CONSTANTS[value]
    if _EXP_FLOAT(value):
        return float(value)
    # Rare scalars (.inf, yes, 1e+3, dates, plain strings): PyYAML's own resolver and constructor decide.
    loader = _resolver()
    node = yaml.ScalarNode(loader.resolve(yaml.ScalarNode, value, (True, False)), value)
    if node.tag == _MERGE:
        raise _Fallback  # a merge key `<<`: PyYAML merges
    return loader.construct_object(node)


class _Fallback(Exception):
    """The document uses a feature the fast path does not handle."""


_RESOLVER: list[Any] = []


def _resolver() -> Any:
    if not _RESOLVER:
        _RESOLVER.append(yaml.SafeLoader(""))
    return _RESOLVER[0]


def safe_load(text: str) -> Any:
    """Parse one YAML document like ``yaml.safe_load``, with this module's rules (raises ``yaml.YAMLError``)."""
    try:
        return _build(text)
    except _Fallback:
        return yaml.load(text, Loader=GuardedLoader)


def _build(text: str) -> Any:
    builder = _Builder()
    handlers = builder.handlers
    for event in yaml.parse(text, Loader=_BASE_LOADER):
        handler = handlers.get(type(event))
        if handler is not None:  # stream and document ends carry nothing
            handler(event)
    return builder.root


class _Builder:
    """Python data built from libyaml's events, one method per event kind (``handlers``); ``root`` at the end.

    Each method reads the attributes its event kind has (ScalarEvent, collection start and end events, ...).
    """

    def __init__(self) -> None:
        self.stack: list[Any] = []
        self.keys: list[Any] = []
        # Per open mapping: key -> line of its first occurrence (duplicate keys are errors naming both lines).
        self.lines: list[dict[Any, int] | None] = []
        self.root: Any = None
        self.documents = 0
        self.handlers: dict[type, Callable[[Any], None]] = {
            yaml.ScalarEvent: self.scalar,
            yaml.MappingStartEvent: self.start,
            yaml.SequenceStartEvent: self.start,
            yaml.MappingEndEvent: self.end,
            yaml.SequenceEndEvent: self.end,
            yaml.AliasEvent: self.alias,
            yaml.DocumentStartEvent: self.document,
        }

    def add(self, value: Any, event: Any) -> None:
        stack = self.stack
        if not stack:
            self.root = value
            return
        top = stack[-1]
        keys = self.keys
        if isinstance(top, list):
            top.append(value)
        elif keys[-1] is _NO_KEY:
            if isinstance(value, (dict, list)):
                raise _Fallback  # complex keys: leave them to PyYAML
            seen = self.lines[-1]
            assert seen is not None
            try:
                if value in top:
                    raise YamlLimitError(_duplicate(value, seen[value]), event.start_mark)
            except TypeError:
                raise _Fallback from None  # an unhashable key: PyYAML reports it
            seen[value] = event.start_mark.line + 1
            keys[-1] = value
        else:
            top[keys[-1]] = value
            keys[-1] = _NO_KEY

    def scalar(self, event: Any) -> None:
        if event.anchor is not None or (event.tag is not None and event.tag != "!"):
            raise _Fallback
        self.add(_plain(event.value) if event.implicit[0] and not event.style else event.value, event)

    def start(self, event: Any) -> None:
        if event.anchor is not None or (event.tag is not None and not event.implicit):
            raise _Fallback
        mapping = type(event) is yaml.MappingStartEvent
        container: Any = {} if mapping else []
        self.add(container, event)
        self.stack.append(container)
        self.keys.append(_NO_KEY)
        self.lines.append({} if mapping else None)

    def end(self, event: Any) -> None:
        self.stack.pop()
        self.keys.pop()
        self.lines.pop()

    def alias(self, event: Any) -> None:
        raise _Fallback

    def document(self, event: Any) -> None:
        self.documents += 1
        if self.documents > 1:
            raise _Fallback  # let PyYAML report "expected a single document"


_NO_KEY = object()
