"""The model computes: no module of evtribo.model plots or writes files, and the command
line's table comes from evtribo.model.point."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

import evtribo.model
from evtribo.cli import main
from evtribo.model.point import POINT_KEYS, evaluate_point

MODEL = Path(evtribo.model.__file__).parent
#: What a pure model does not use: plotting, and writing files.
_NOT_PURE = {"matplotlib", "evtribo.store.files", "os", "shutil", "pathlib"}


@pytest.mark.parametrize("path", sorted(MODEL.glob("*.py")), ids=lambda p: p.name)
def test_model_module_neither_plots_nor_writes(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module)
    wrong = {m for m in imported if m.split(".")[0] in _NOT_PURE or m in _NOT_PURE}
    assert not wrong, wrong
    calls = [n.func.id for n in ast.walk(tree)
             if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)]
    assert "open" not in calls


def test_the_command_line_prints_evaluate_point(capsys):
    assert main(["model", "--normal-force", "0.7", "--voltage", "90", "--frequency", "200",
                 "--waveform", "sine", "--set", "r_g=80", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    point = evaluate_point(0.7, 90.0, evtribo.model.TABLE_1.with_values(r_g=80.0),
                           frequency=200.0, waveform="sine")
    assert tuple(point) == POINT_KEYS
    assert {k: printed[k] for k in POINT_KEYS} == point
