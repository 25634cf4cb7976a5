"""Diagrams of the UAV machines with ``transitions``' HierarchicalGraphMachine (graphviz engine).

DOT text needs only the ``graphviz`` Python package; SVG and PNG need graphviz's ``dot`` program.
"""

from __future__ import annotations

import copy
import shutil
from pathlib import Path
from typing import Any

from masonry.fsm.states import MACHINES

FORMATS = ("svg", "png", "dot")


def machine_graph(kind: str) -> Any:
    """The nested machine ``kind`` (``brick`` or ``adhesion``) as a ``graphviz.Digraph``, conditions shown."""
    from transitions.extensions import HierarchicalGraphMachine

    if kind not in MACHINES:
        raise ValueError(f"unknown machine {kind!r}: expected one of {', '.join(MACHINES)}")
    states, transitions = MACHINES[kind]
    machine = HierarchicalGraphMachine(
        states=copy.deepcopy(states),
        transitions=copy.deepcopy(transitions),
        initial="idle",
        queued=True,
        auto_transitions=False,
        graph_engine="graphviz",
        show_conditions=True,
        title=f"masonry {kind} UAV",
    )
    return machine.get_graph()


def dot_available() -> bool:
    """Is graphviz's ``dot`` program on the PATH (needed for SVG and PNG)?"""
    return shutil.which("dot") is not None


def write_diagram(kind: str, path: Path) -> None:
    """Write the diagram of machine ``kind`` to ``path`` (.svg, .png or .dot, from the suffix).

    Raises:
        ValueError: an unknown machine or file suffix.
        FileNotFoundError: SVG/PNG asked for but ``dot`` is not installed.
    """
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise ValueError(f"{path}: the file must end in .svg, .png or .dot")
    graph = machine_graph(kind)
    if fmt == "dot":
        path.write_text(graph.source)
        return
    if not dot_available():
        raise FileNotFoundError("graphviz's `dot` program is not installed")
    path.write_bytes(graph.pipe(format=fmt))
