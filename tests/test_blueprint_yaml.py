"""The fast blueprint YAML reader gives exactly what yaml.safe_load gives."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from masonry.blueprint_yaml import safe_load

ROOT = Path(__file__).resolve().parents[1]

DOCUMENTS = [
    "a: 1\nb: -2.5\nc: [1, 2.0, .inf, -.nan, yes, No, ~, null, '1', \"2\", 1e+3, 0x1F, 012, 1_000, 2001-12-14]\n",
    "c: [+1, 1., .5, -.5e+2, 0.0, -0.0, 00, 0b11, 1:30, http://x, a b c, 'q: r']\n",
    "- {x: true, y: False}\n- !!str 3\n",
    "a: &x [1]\nb: *x\n",
    "",
    "# only a comment\n",
    "just a string",
    "{a: {b: {c: []}}}",
    "a: 1\na: 2\n",
    "a: |\n  text\n  more\nb: >\n  folded\n  text\n",
    "a: plain\n  continued\n",
]


@pytest.mark.parametrize("text", DOCUMENTS)
def test_same_as_safe_load(text: str) -> None:
    assert repr(safe_load(text)) == repr(yaml.safe_load(text))


@pytest.mark.parametrize("text", ["a: [1, 2", "a: 1\n---\nb: 2\n", "a: b: c\n", "? [1, 2]\n: 3\n"])
def test_same_errors(text: str) -> None:
    with pytest.raises(yaml.YAMLError):
        yaml.safe_load(text)
    with pytest.raises(yaml.YAMLError):
        safe_load(text)


@pytest.mark.parametrize("path", sorted((ROOT / "blueprints").glob("*.yaml")), ids=lambda p: p.name)
def test_bundled_blueprints(path: Path) -> None:
    text = path.read_text()
    assert safe_load(text) == yaml.safe_load(text)
