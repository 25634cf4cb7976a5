"""The fast blueprint YAML reader gives exactly what yaml.safe_load gives, but for its three rules (duplicate keys
are errors, YAML 1.2 exponent floats are numbers, alias expansion is bounded)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from masonry.blueprint_yaml import GuardedLoader, safe_load

ROOT = Path(__file__).resolve().parents[1]

DOCUMENTS = [
    "a: 1\nb: -2.5\nc: [1, 2.0, .inf, -.nan, yes, No, ~, null, '1', \"2\", 0x1F, 012, 1_000, 2001-12-14]\n",
    "c: [+1, 1., .5, 0.0, -0.0, 00, 0b11, 1:30, http://x, a b c, 'q: r']\n",
    "- {x: true, y: False}\n- !!str 3\n",
    "a: &x [1]\nb: *x\n",
    "",
    "# only a comment\n",
    "just a string",
    "{a: {b: {c: []}}}",
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


@pytest.mark.parametrize(
    "text",
    [
        *DOCUMENTS,
        "c: [1e+3, 5e-2, 1e9, -2E4, .5e1, 1.e2, -.5e+2, '1e9', 1e9x]\n",
        "base: &b {x: 1, y: 2}\nc: {<<: *b, y: 3}\n",
    ],
)
def test_fast_path_same_as_guarded_pyyaml(text: str) -> None:
    """The fast path and PyYAML with the same rules (the fallback for anchors, tags, merges) agree."""
    assert repr(safe_load(text)) == repr(yaml.load(text, Loader=GuardedLoader))


def test_exponent_floats_are_numbers() -> None:
    assert safe_load("c: [1e+3, 5e-2, 1e9, '1e9', 1e9x]") == {"c": [1000.0, 0.05, 1e9, "1e9", "1e9x"]}
    assert safe_load("a: &x 5e-2\nb: *x\n") == {"a": 0.05, "b": 0.05}


@pytest.mark.parametrize("text", ["a: 1\na: 2\n", "{a: 1, a: 2}", "a: &x 1\nb: {c: *x, c: 2}\n"])
def test_duplicate_keys_are_errors(text: str) -> None:
    with pytest.raises(yaml.YAMLError, match=r"duplicate key 'a'|duplicate key 'c'"):
        safe_load(text)
