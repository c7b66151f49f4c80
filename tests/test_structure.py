"""The package's shape: lower layers never import higher ones, modules and functions stay
short enough to read."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).parents[1] / "src" / "evtribo"

#: Each top-level module or package of evtribo and its layer: a module imports only from
#: lower layers (or its own package).
LAYERS = {
    "evtribo": 0, "errors": 0, "_docs": 0,
    "files": 1, "median": 1, "running": 1, "outages": 1, "citation": 1, "memo": 2,
    "documents": 2, "dbc_file": 2,
    "model": 2, "frames": 2, "signal_codec": 2, "lock": 2, "resultdir": 2, "dropped": 2,
    "signals": 2,
    "rig": 3, "frame_match": 3,
    "study": 4, "decode": 4,
    "cache": 5, "decode_table": 5, "decode_mf4": 5, "guard": 5,
    "analysis": 6, "acquisition": 6,
    "compare": 7, "rigsetup": 7, "session": 7,
    "demo": 8, "api": 8,
    "cli": 9, "__main__": 10,
}
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80
#: Functions still being split into named steps, by package (each must be over the limit:
#: a function brought under it leaves its set).
LONG_IN_ANALYSIS: set[str] = set()

LONG_IN_ACQUISITION: set[str] = set()

LONG_IN_COMPARE: set[str] = set()

LONG_FUNCTIONS = LONG_IN_ANALYSIS | LONG_IN_ACQUISITION | LONG_IN_COMPARE
#: Modules still being split.
LONG_MODULES: set[str] = set()

def _modules():
    for path in sorted(SRC.rglob("*.py")):
        yield path, ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _part(dotted: str) -> str:
    parts = dotted.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def test_lower_layers_never_import_higher_ones():
    wrong = []
    for path, tree in _modules():
        rel = path.relative_to(SRC)
        me = rel.parts[0].removesuffix(".py") if len(rel.parts) > 1 or rel.stem != "__init__" \
            else "evtribo"
        for node in ast.walk(tree):
            names = ([node.module] if isinstance(node, ast.ImportFrom) and node.module
                     and node.level == 0 else
                     [a.name for a in node.names] if isinstance(node, ast.Import) else [])
            for name in names:
                if not name.startswith("evtribo"):
                    continue
                other = _part(name)
                if other != me and LAYERS[other] >= LAYERS[me]:
                    wrong.append(f"{rel}:{node.lineno} imports {name}")
    assert not wrong, "\n".join(wrong)


def test_every_module_has_a_layer():
    tops = {p.relative_to(SRC).parts[0].removesuffix(".py") for p in SRC.rglob("*.py")}
    assert tops - {"__init__"} <= set(LAYERS), tops - set(LAYERS)


def test_modules_and_functions_are_short():
    long_modules, long_functions = set(), set()
    for path, tree in _modules():
        rel = path.relative_to(SRC).as_posix()
        if path.read_text(encoding="utf-8").count("\n") > MAX_MODULE_LINES:
            long_modules.add(rel)
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and \
                    node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES:
                long_functions.add(f"{rel}:{node.name}")
    assert long_modules == LONG_MODULES
    assert long_functions == LONG_FUNCTIONS
