"""The package's shape: lower layers never import higher ones, each module holds one thing and
says what, functions stay short enough to read, and what a docstring points at is there."""

from __future__ import annotations

import ast
import re
from pathlib import Path

SRC = Path(__file__).parents[1] / "src" / "evtribo"

#: Each top-level module or package of evtribo and its layer: a module imports only from
#: lower layers (or its own package).
LAYERS = {
    "evtribo": 0, "errors": 0, "util": 0,
    "citation": 1, "store": 1, "warning": 1,
    "documents": 2, "model": 2,
    "canlog": 3,
    "study": 4,
    "guard": 5,
    "analysis": 6, "acquisition": 6,
    "results": 7, "rigsetup": 7,
    "fit": 8, "session": 8,
    "population": 9,
    "figures": 10,
    "report": 11,
    "demo": 12, "api": 12,
    "cli": 13, "__main__": 14,
}
MAX_FUNCTION_LINES = 80
#: Functions still being split into named steps, by package (each must be over the limit:
#: a function brought under it leaves its set).
LONG_IN_ANALYSIS: set[str] = set()

LONG_IN_ACQUISITION: set[str] = set()

LONG_IN_COMPARE: set[str] = set()

LONG_FUNCTIONS = LONG_IN_ANALYSIS | LONG_IN_ACQUISITION | LONG_IN_COMPARE
#: A module over this many lines is read as doing more than one thing, whatever its graph says.
MAX_MODULE_LINES = 1000
#: The command line's modules: reached through the ``evtribo`` command (``cli/__init__.py``'s
#: ``SUBCOMMANDS`` imports each one's ``add_parser`` and ``run``), they offer no Python names
#: and need no ``__all__``.
COMMAND_LINE = ("cli/", "__main__.py")
_FORMULAS = "the model's equations, one function each (docs/models.md), none calling another"
_DOCUMENT = ("a document's format: its file name and version, its keys, its reader and its "
             "writer, each used apart by the modules that read or write it")
_CONSTANTS = "a module of constants or names other modules share, each used where it is read"
#: Modules whose public names form more than one group of the graph of their top-level
#: definitions (:func:`_public_groups`) and are one thing nevertheless: each with why.
COLLECTIONS = {
    "errors.py": "the error tree, and the two helpers that point an error at a TOML key",
    "analysis/modes.py": _CONSTANTS,
    "documents/quantities.py": "the relative friction increase: its formula, heading and "
                               "definition, each used where it is shown",
    "model/contact.py": _FORMULAS, "model/electrostatics.py": _FORMULAS,
    "model/friction.py": _FORMULAS,
    "documents/fit.py": _DOCUMENT, "documents/summary.py": _DOCUMENT,
    "documents/sidecar.py": _DOCUMENT,
    "population/models/__init__.py": "the population models' registry, its default and the "
                                     "meta-analysis's name",
    "util/running.py": "runs of a series: moving sums and counts, runs of equal values",
    "warning/record.py": "a warning record and what it is made of: its kind's effect, its "
                         "scope, its level",
    "warning/collect.py": "how records are said and collected, and a record moved to another "
                          "scope on the way",
    "warning/legacy_compare.py": "an earlier fit.json's notes lifted into records: the "
                                 "patterns, the kinds only they say, and the lifting",
    "warning/legacy.py": "an earlier result's sentences lifted into records: the patterns, "
                         "the lifting, the texts merged",
    "figures/style.py": "the journal style: sizes, widths, formats, colours, markers and the "
                        "axes drawn in it",
    "figures/layout.py": "where a figure's parts go: log axes and their ticks, legends placed "
                         "clear of the data",
    "figures/plots.py": "the per-subject friction figures of compare and their saving",
    "figures/population_plots.py": "the population figure, its file stem and its caption",
    "figures/log_plots.py": "a log's signals decoded and drawn, and the channel the switch is "
                            "read from",
    "figures/trial_checks.py": "the trial checks compare draws: which trials, their figures "
                               "and their resolution",
    "api/fit.py": "evtribo.compare and the Fit it returns, with fit.csv's text columns",
    "api/results.py": "evtribo.analyze and the Results it returns, with the tables' readers",
    "report/headline.py": "the report's first tables: forces, friction, fit, models, and "
                          "how to cite what it rests on",
    "report/study_files.py": "what the report reads of the study folder: its name, rig, "
                             "inputs and their hashes, the trials' notes",
    "report/drawing.py": "the figures drawn for a report, and the trials it checks",
    "report/friction_report.py": "the report's friction section: per subject and per trial",
    "report/compare_cache.py": "what compare keeps from its last run: the keys and the "
                               "figures under them",
    "report/lead/analysed.py": "the paragraph and table of what was analysed",
    "report/lead/marks.py": "the marks a cell carries for its warnings, and their anchors",
    "report/lead/sections.py": "the key results', analysed and warnings sections of the "
                               "report's lead",
    "results/outputs.py": "a result folder's files: which, who writes each, and the "
                          "refusals before anything is written",
    "results/distributed.py": "analysing on a Dask cluster: connecting, mapping, counting its "
                              "threads",
    "fit/intervals.py": "the fit's intervals: covariance and refitted replicates",
    "fit/tables.py": "the tables compare reads (ResultTables) and the replicate matrix made "
                     "from them",
    "population/data.py": "the population's data: each subject's cells, their conditions and "
                          "the tables' columns",
    "analysis/settings.py": "the analysis settings: their fields, bounds, help texts and "
                            "parsing",
    "analysis/piece_observer.py": "what the analysis hands out of each piece, and the lifted "
                                  "stretches it excludes",
    "analysis/forces/crosstalk.py": "the load cells' cross-talk: reversal sums, its notes, the "
                                    "share of each direction",
    "analysis/forces/hum.py": "the mains hum: found and removed, and friction that oscillates "
                              "beside it",
    "analysis/forces/pieces.py": "a trial's continuous pieces and the gaps between them",
    "analysis/friction/drift.py": "the friction's drift over a trial and its notes",
    "analysis/friction/estimate.py": "the electrostatic force estimated from a subject's "
                                     "windows, the coefficient and the mean inferred force",
    "analysis/friction/sine.py": "a sine drive's friction: its modulation and the trace "
                                 "around a switch",
    "analysis/friction/window_facts.py": "where a window lies in its trial, and the time "
                                         "polynomial its models use",
    "canlog/decode_table.py": "a log decoded into a table, and the DBC it is decoded with",
    "canlog/io/candump_line.py": "one candump line parsed, and a line read with a bound",
    "canlog/io/ids.py": "a frame's identifier: its key and its text",
    "canlog/io/table.py": "a table of frames: its payloads' widths, and the channel and the "
                          "time no frame has",
    "cli/_startup.py": "what the command does before it imports: one BLAS thread, the heavy "
                       "imports started",
    "cli/recording/_bounds.py": "the recording options' bounds",
    "cli/setup/_signals.py": "SIGTERM as an interruption, and its exit code",
    "acquisition/buses/bus.py": "a bus opened from its settings, and its options parsed",
    "acquisition/live/display.py": "the live display's lines, and its no-rig-data alert",
    "acquisition/protocol.py": "a protocol: read, planned, and its examples",
    "acquisition/replace.py": "a trial recorded again: its new stage, committed or discarded",
    "acquisition/rigfile.py": "a study's rig for recording: created, loaded, checked",
    "acquisition/trialdata.py": "what a recording is given and gives back, and the disk "
                                "space it keeps in reserve",
    "acquisition/simulator/physics.py": "the simulated finger's physics, the model's "
                                        "parameters and the ON/OFF schedule",
    "acquisition/simulator/realism.py": "a realistic rig and subject beside the ideal ones",
    "rigsetup/roles.py": "the rig's signals' roles guessed, and their behaviour said",
    "session/trialfiles.py": "a session's trial files: found, rejected, the first free name",
    "store/files.py": "whole files: written atomically, read bounded, checksummed entries",
    "store/owned.py": "which files evtribo may replace: checks and claims",
    "store/pool.py": "the worker processes: the pool, their start and their stop",
}

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


def test_functions_are_short():
    long_functions = set()
    for path, tree in _modules():
        rel = path.relative_to(SRC).as_posix()
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and \
                    node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES:
                long_functions.add(f"{rel}:{node.name}")
    assert long_functions == LONG_FUNCTIONS


def test_no_module_is_past_the_backstop():
    """However connected its names, a module this long does more than one thing."""
    long = {path.relative_to(SRC).as_posix(): n for path, _ in _modules()
            if (n := path.read_text(encoding="utf-8").count("\n")) > MAX_MODULE_LINES}
    assert not long, long


def _public_names(tree: ast.Module) -> list[str] | None:
    """A module's ``__all__``, or None without one."""
    for node in tree.body:
        if isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                assert isinstance(node.value, ast.List | ast.Tuple)
                return [e.value for e in node.value.elts if isinstance(e, ast.Constant)]
    return None


def _first_sentence(doc: str) -> str:
    return re.split(r"(?<=\.)\s", " ".join(doc.split()), maxsplit=1)[0]


def test_every_module_says_what_it_holds():
    """Each module opens with a docstring whose first sentence names what it holds (a few
    words at least), and lists its public names in ``__all__`` (the command line's modules
    but their package, :data:`COMMAND_LINE`, offer none); every name listed is defined or
    imported there (or, in a package that imports its names when first asked for, found by
    its ``__getattr__``)."""
    wrong = []
    for path, tree in _modules():
        rel = path.relative_to(SRC).as_posix()
        doc = ast.get_docstring(tree) or ""
        if len(_first_sentence(doc).split()) < 3:
            wrong.append(f"{rel}: no first sentence saying what it holds")
        public = _public_names(tree)
        if public is None:
            if not rel.startswith(COMMAND_LINE) or rel == "cli/__init__.py":
                wrong.append(f"{rel}: no __all__")
            continue
        bound = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)
                 and isinstance(n.ctx, ast.Store)}
        bound |= {n.name for n in ast.walk(tree) if isinstance(
            n, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef)}
        bound |= {(a.asname or a.name).split(".")[0] for n in ast.walk(tree)
                  if isinstance(n, ast.Import | ast.ImportFrom) for a in n.names}
        if "__getattr__" not in bound:
            wrong += [f"{rel}: __all__ names {n}, not defined there" for n in public
                      if n not in bound]
    assert not wrong, "\n".join(wrong)


def _words(text: str) -> set[str]:
    return set(re.findall(r"[A-Za-z_]\w*", text))


def _definitions(tree: ast.Module, lines: list[str]) -> dict[str, set[str]]:
    """Each top-level definition of a module (a function, a class, a constant; a statement
    that defines nothing, such as a registration, counts as one) and the names it uses: in
    its code, its docstring and the ``#:`` comment above it."""
    defs: dict[str, set[str]] = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names = [node.name]
        elif isinstance(node, ast.Assign | ast.AnnAssign | ast.AugAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names = [n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)]
        elif isinstance(node, ast.Expr) and not isinstance(node.value, ast.Constant):
            names = [f"<line {node.lineno}>"]
        else:
            continue
        used = set()
        for inner in ast.walk(node):
            if isinstance(inner, ast.Name):
                used.add(inner.id)
            elif isinstance(inner, ast.Constant) and isinstance(inner.value, str):
                used |= _words(inner.value)  # annotations as text, docstrings
        i = node.lineno - 2
        while 0 <= i < len(lines) and lines[i].lstrip().startswith("#:"):
            used |= _words(lines[i])
            i -= 1
        for name in names:
            if name != "__all__":
                defs.setdefault(name, set()).update(used)
    return defs


def _public_groups(tree: ast.Module, lines: list[str], public: list[str]) -> list[list[str]]:
    """A module's public names grouped by the graph of its top-level definitions (an edge
    where one names another, either way): names in one group work together."""
    defs = _definitions(tree, lines)
    linked: dict[str, set[str]] = {name: set() for name in defs}
    for name, used in defs.items():
        for other in used & set(defs) - {name}:
            linked[name].add(other)
            linked[other].add(name)
    groups, seen = [], set()
    for name in public:
        if name in seen or name not in linked:
            continue
        group, todo = set(), [name]
        while todo:
            here = todo.pop()
            if here not in group:
                group.add(here)
                todo += linked[here]
        seen |= group
        groups.append(sorted(group & set(public)))
    return groups


def test_each_module_does_one_thing():
    """A module's public names form one group in the graph of its top-level definitions, or
    the module is a collection :data:`COLLECTIONS` names with its reason (and leaves it once
    its names are one group)."""
    split, listed = {}, set()
    for path, tree in _modules():
        rel = path.relative_to(SRC).as_posix()
        public = _public_names(tree)
        if not public:
            continue
        groups = _public_groups(tree, path.read_text(encoding="utf-8").splitlines(), public)
        if len(groups) > 1:
            listed.add(rel)
            if rel not in COLLECTIONS:
                split[rel] = " | ".join(", ".join(g) for g in groups)
    assert not split, "modules doing more than one thing:\n" + "\n".join(
        f"{k}: {v}" for k, v in sorted(split.items()))
    assert set(COLLECTIONS) <= listed, f"one thing now: {sorted(set(COLLECTIONS) - listed)}"


def test_the_one_thing_check_finds_two():
    """The check above sees two unrelated functions as two things, and one calling the other
    (or a helper both use) as one."""
    two = ast.parse("def a():\n    return 1\n\n\ndef b():\n    return 2\n")
    one = ast.parse("def _h():\n    return 1\n\n\ndef a():\n    return _h()\n\n\n"
                    "def b():\n    return _h()\n")
    assert len(_public_groups(two, [], ["a", "b"])) == 2
    assert len(_public_groups(one, [], ["a", "b"])) == 1


#: A reference of a docstring: ``:func:`x```, ``:class:`~a.b```, and the like.
_ROLE = re.compile(r":(mod|func|class|data|meth|attr|exc|obj):`([^`]+)`")
#: A module of the package or a page of the documentation, in backticks:
#: ``analysis/trial.py``, ``docs/analysis.md``.
_DOC_PATH = re.compile(r"`+((?:[\w.-]+/)+[\w-]+\.py|docs/[\w/-]+\.md)`+")
_ABSENT = object()


def _find(dotted: str) -> object:
    """The object *dotted* names (a module, then attributes), or :data:`_ABSENT`."""
    import importlib

    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr, _ABSENT)
        return obj
    return _ABSENT


def _instance_attribute(dotted: str) -> bool:
    """Whether *dotted* is ``class.attribute`` of an attribute its instances have (a field,
    an annotation, one set on ``self``)."""
    import inspect

    owner, _, name = dotted.rpartition(".")
    cls = _find(owner) if owner else _ABSENT
    if not inspect.isclass(cls):
        return False
    for base in cls.__mro__:
        if name in getattr(base, "__annotations__", {}) or name in vars(base):
            return True
        try:
            if re.search(rf"self\.{name}\b\s*(:[^=\n]*)?=", inspect.getsource(base)):
                return True
        except (OSError, TypeError):
            continue
    return False


def _resolves(target: str, module: str, cls: str | None, modules: list[str]) -> bool:
    """Whether a reference finds what Sphinx would look for: a full name, a name of the
    module or of its class, a builtin, or (``.name``) any object whose name ends so."""
    import builtins

    target = re.sub(r"\s+", "", target).removeprefix("~")
    if "<" in target:
        target = target[target.index("<") + 1:].rstrip(">")
    if target.startswith("."):
        return any(_find(f"{m}{target}") is not _ABSENT for m in modules)
    places = [target] if target.startswith("evtribo.") else \
        [*([f"{module}.{cls}.{target}"] if cls else []), f"{module}.{target}", target]
    if hasattr(builtins, target.split(".")[0]):
        places.append(f"builtins.{target}")
    return any(_find(p) is not _ABSENT or _instance_attribute(p) for p in places)


def _docstrings_with_class(tree: ast.Module):
    """Each docstring of a module, with the class it is read in (None at the top level)."""
    def walk(node: ast.AST, cls: str | None):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                here = child.name if isinstance(child, ast.ClassDef) else cls
                doc = ast.get_docstring(child, clean=False)
                if doc:
                    yield child.lineno, doc, here
                yield from walk(child, here)
    yield 1, ast.get_docstring(tree, clean=False) or "", None
    yield from walk(tree, None)


def test_every_reference_in_a_docstring_resolves():
    """Every ``:mod:``, ``:func:``, ``:class:``, ``:data:``, ``:meth:``, ``:attr:`` and
    ``:exc:`` of a docstring names what is there (a module, a name it defines or imports, an
    attribute of a class), and every backticked path (``analysis/trial.py``,
    ``docs/analysis.md``) is a file of the package, beside the module, or of the
    repository."""
    import pkgutil

    import evtribo

    modules = ["evtribo", *(m.name for m in pkgutil.walk_packages(evtribo.__path__,
                                                                  "evtribo."))]
    wrong, seen = [], 0
    for path, tree in _modules():
        rel = path.relative_to(SRC)
        parts = ("evtribo", *rel.with_suffix("").parts)
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for line, doc, cls in _docstrings_with_class(tree):
            for role, target in _ROLE.findall(doc):
                seen += 1
                if not _resolves(target, module, cls, modules):
                    wrong.append(f"{rel}:{line} :{role}:`{target}`")
            for name in _DOC_PATH.findall(doc):
                seen += 1
                if not any((base / name).exists() for base in (SRC, path.parent, ROOT)):
                    wrong.append(f"{rel}:{line} `{name}`")
    assert seen > 500  # the patterns still read the docstrings
    assert not wrong, "references to what is not there:\n" + "\n".join(wrong)


#: Most modules directly in one folder of the package (its ``__init__.py`` not counted), and
#: directly in ``src/evtribo`` (``__init__.py`` and ``__main__.py`` counted).
MAX_MODULES_IN_A_FOLDER = 12
MAX_MODULES_AT_THE_ROOT = 8


def test_each_folder_holds_a_few_modules():
    crowded = {}
    for folder in [SRC, *(p for p in SRC.rglob("*") if p.is_dir())]:
        if folder.name == "__pycache__" or not (folder / "__init__.py").is_file():
            continue
        modules = [p.name for p in folder.glob("*.py") if p.name != "__init__.py"]
        if len(modules) > MAX_MODULES_IN_A_FOLDER:
            crowded[folder.relative_to(SRC).as_posix()] = len(modules)
    assert not crowded, crowded
    assert len(list(SRC.glob("*.py"))) <= MAX_MODULES_AT_THE_ROOT


def _module_graph() -> dict[str, set[str]]:
    """Each module of evtribo and the modules of evtribo it imports anywhere (type hints,
    functions included): ``from evtribo.x import y`` counts as importing ``evtribo.x.y`` when
    that is a module, else ``evtribo.x``."""
    names = {}
    for path in SRC.rglob("*.py"):
        parts = ("evtribo", *path.relative_to(SRC).with_suffix("").parts)
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph: dict[str, set[str]] = {}
    for name, path in names.items():
        out = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module in names:
                for alias in node.names:
                    sub = f"{node.module}.{alias.name}"
                    out.add(sub if sub in names else node.module)
            elif isinstance(node, ast.Import):
                out |= {a.name for a in node.names if a.name in names}
        out.discard(name)
        graph[name] = out
    return graph


def test_no_import_circles():
    graph = _module_graph()
    circles = []
    for start in graph:  # a path back to the start from any module it imports
        seen, todo = set(), [(m, (start, m)) for m in graph[start]]
        while todo:
            mod, path = todo.pop()
            if mod == start:
                circles.append(" -> ".join(path))
                break
            if mod in seen:
                continue
            seen.add(mod)
            todo += [(m, (*path, m)) for m in graph.get(mod, ())]
    assert not circles, "\n".join(sorted(circles))


#: Names with a leading underscore that the standard library documents as public.
DOCUMENTED = {"os._exit"}


def test_no_private_api_of_the_standard_library():
    import sys

    stdlib = set(sys.stdlib_module_names)
    used = []
    for path, tree in _modules():
        aliases = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.split(".")[0] in stdlib:
                        aliases[a.asname or a.name.split(".")[0]] = a.name
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0 and \
                    node.module.split(".")[0] in stdlib:
                used += [f"{path.relative_to(SRC)}:{node.lineno} {node.module}.{a.name}"
                         for a in node.names if a.name.startswith("_")]
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and \
                    node.value.id in aliases and node.attr.startswith("_") and \
                    not node.attr.startswith("__"):
                used.append(f"{path.relative_to(SRC)}:{node.lineno} "
                            f"{aliases[node.value.id]}.{node.attr}")
    assert not [u for u in used if u.split()[-1] not in DOCUMENTED], used


ROOT = SRC.parents[1]
ARCHITECTURE = ROOT / "docs" / "architecture.md"
#: A path or a folder as docs/architecture.md names one: ``analysis/trial.py``, ``store/``,
#: ``tests/_vcanvm.py``, ``docs/models.md``, or a module alone, ``data.py``.
_PATH = re.compile(r"(?<![\w./<-])([A-Za-z_][\w-]*(?:/[\w-]+)*(?:\.py|\.md|/))(?![\w/<*])")


def _named_in_architecture() -> list[list[str]]:
    """The paths docs/architecture.md names, by the stretch of text they are read in: a table
    row or a paragraph (what is in backticks), or one top-level entry of a diagram with the
    lines under it (every name that looks like a path)."""
    units: list[list[str]] = [[]]
    fenced = False
    for line in ARCHITECTURE.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            fenced = not fenced
            units.append([])
        elif fenced:
            if len(line) - len(line.lstrip()) <= 2:  # a top-level entry starts a new stretch
                units.append([])
            units[-1] += _PATH.findall(line)
        else:
            if not line.strip() or line.startswith("|"):
                units.append([])
            units[-1] += [m for code in re.findall(r"`([^`]+)`", line)
                          for m in _PATH.findall(code) if code.startswith(m)]
    return units


def _resolve(name: str, contexts: list[Path]) -> Path | None:
    """*name* where it is: under a folder named before it in the same stretch, in
    ``src/evtribo``, or in the repository."""
    for base in (*reversed(contexts), SRC, ROOT):
        if (base / name).exists():
            return base / name
    return None


def test_every_path_architecture_md_names_exists():
    """docs/architecture.md is where a newcomer looks things up: every module, folder and page
    it names is there (a bare module name under a folder of the package named before it in
    the same table row, paragraph or diagram entry, or at the top of the package)."""
    missing = []
    for names in _named_in_architecture():
        contexts: list[Path] = []
        for name in names:
            found = _resolve(name, contexts)
            if found is None:
                missing.append(name)
            elif not found.is_relative_to(SRC):  # tests/, docs/: no package's modules
                continue
            elif "/" in name.rstrip("/"):
                contexts.append(found if found.is_dir() else found.parent)
            elif found.is_dir():
                contexts.append(found)
    assert not missing, f"docs/architecture.md names what is not there: {sorted(set(missing))}"


def test_every_dotted_name_architecture_md_names_exists():
    """Each ``evtribo.x.y`` in docs/architecture.md is a module of the package or a name one of
    its modules defines."""
    import importlib

    text = ARCHITECTURE.read_text(encoding="utf-8")
    missing = []
    for dotted in sorted(set(re.findall(r"`(evtribo(?:\.\w+)+)`", text))):
        where = SRC.joinpath(*dotted.split(".")[1:])
        if where.with_suffix(".py").is_file() or (where / "__init__.py").is_file():
            continue
        parent, _, attr = dotted.rpartition(".")
        if not hasattr(importlib.import_module(parent), attr):
            missing.append(dotted)
    assert not missing, missing


def test_the_layers_architecture_md_gives_are_the_ones_checked():
    """The table of layers in docs/architecture.md gives every top-level module the layer
    :data:`LAYERS` holds it to."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    documented = {name.removesuffix("/").removesuffix(".py"): int(layer)
                  for layer, cell in re.findall(r"^\| (\d+) \| ([^|]+) \|", text, re.M)
                  for name in re.findall(r"`([\w.]+/?)`", cell)}
    expected = {k: v for k, v in LAYERS.items() if k not in ("evtribo", "__main__")}
    assert documented == expected


def test_the_forces_import_nothing_else_of_the_analysis():
    """``analysis/forces/`` is the floor the rest of the analysis stands on (the friction, the
    trial's steps): none of its modules imports from ``analysis`` outside ``forces``."""
    wrong = []
    for path, tree in _modules():
        if path.parent != SRC / "analysis" / "forces":
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and \
                    node.module.startswith("evtribo.analysis") and \
                    not node.module.startswith("evtribo.analysis.forces"):
                wrong.append(f"{path.relative_to(SRC)}:{node.lineno} imports {node.module}")
    assert not wrong, "\n".join(wrong)


#: ``module.py`` followed by the names it holds: ``(`a`, `b`)`` or ``'s `a` and `b```.
_HOLDS = re.compile(r"`([\w/]+\.py)`(?: \(([^)]*)\)|'s ((?:`[\w.]+`(?:, | and |/))*`[\w.]+`))")


def test_every_name_architecture_md_places_in_a_module_is_there():
    """Where docs/architecture.md says a module holds a function, a class or a constant
    (``results/trial_view.py`` (``view_trial``), ``cli/__init__.py``'s ``GROUPS``), the module
    has it."""
    import importlib

    text = ARCHITECTURE.read_text(encoding="utf-8")
    absent = object()
    missing, checked = [], 0
    for line in text.splitlines():
        contexts: list[Path] = []
        for path, inside, owned in _HOLDS.findall(line):
            found = _resolve(path, contexts)
            if found is None or not found.is_relative_to(SRC):
                continue
            contexts.append(found.parent)
            parts = found.relative_to(SRC).with_suffix("").parts
            module = importlib.import_module(".".join(
                ("evtribo", *(parts[:-1] if parts[-1] == "__init__" else parts))))
            for name in re.findall(r"`([A-Za-z_][\w.]*)`", inside or owned):
                if name.endswith(".py") or (ROOT / name).exists():
                    continue
                checked += 1
                obj: object = module
                for attr in name.split("."):
                    obj = getattr(obj, attr, absent)
                if obj is absent:
                    missing.append(f"{path}: {name}")
    assert checked > 20  # the pattern still reads the page
    assert not missing, missing


#: Calls that read a file's bytes or text as they are (a document module's reader is not one).
_RAW_READS = {"read_csv", "read_json", "read_text", "read_bytes", "loads", "load", "open",
              "DictReader", "reader", "read_limited", "read_regular", "open_regular"}


def _result_file_names() -> tuple[set[str], set[str]]:
    """The files of a result folder, and the names of the constants that name them."""
    import evtribo.documents.fit
    import evtribo.documents.summary
    import evtribo.documents.tables
    import evtribo.results.outputs

    files = {*evtribo.documents.tables.SCHEMAS, evtribo.documents.fit.FIT_JSON,
             evtribo.documents.summary.SUMMARY_FILE}
    constants = {name for module in (evtribo.documents.tables, evtribo.documents.fit,
                                     evtribo.documents.summary, evtribo.results.outputs)
                 for name, value in vars(module).items()
                 if isinstance(value, str) and value in files}
    schemas = {name for name, value in vars(evtribo.documents.tables).items()
               if isinstance(value, evtribo.documents.tables.TableSchema)}
    return files, constants | {f"{s}.file" for s in schemas}


def _docstrings(tree: ast.AST) -> set[int]:
    """The ids of the docstring nodes of a module, its classes and functions."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef |
                      ast.AsyncFunctionDef) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def _named(node: ast.AST) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return f"{node.value.id}.{node.attr}" if isinstance(node.value, ast.Name) \
            else node.attr
    return None


def test_only_documents_read_a_result_folders_files():
    """No module outside ``documents/`` spells a result file's name (the tables, fit.json,
    summary.json: their names are :mod:`evtribo.documents.tables`'), calls ``read_csv``, or
    reads a result file's bytes itself: every read goes through the document modules and
    :class:`~evtribo.documents.result_folder.ResultFolder`."""
    files, constants = _result_file_names()
    wrong = []
    for path, tree in _modules():
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith("documents/"):
            continue
        skip = _docstrings(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                    id(node) not in skip and node.value.rsplit("/", 1)[-1] in files:
                wrong.append(f"{rel}:{node.lineno} names {node.value!r}")
            elif isinstance(node, ast.Call) and _named(node.func) in ("read_csv",
                                                                     "pd.read_csv"):
                wrong.append(f"{rel}:{node.lineno} calls read_csv")
        for func in ast.walk(tree):
            if not isinstance(func, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            inner = list(ast.walk(func))
            names = {_named(n) for n in inner} & constants
            reads = {str(_named(n.func)).rsplit(".", 1)[-1] for n in inner
                     if isinstance(n, ast.Call)} & _RAW_READS
            if names and reads:
                wrong.append(f"{rel}:{func.lineno} {func.name} reads {sorted(reads)} "
                             f"beside {sorted(names)}")
    assert not wrong, "\n".join(sorted(set(wrong)))


#: Where the analysis's warnings are said: each as a record of the catalogue (``emit``).
WARNING_SITES = ("study.py", "canlog", "analysis", "results", "session/check.py", "fit",
                 "population", "figures", "report/compare.py", "report/sections.py",
                 "report/population.py", "report/friction_report.py", "api/fit.py",
                 "report/study_report.py", "report/study_files.py", "report/drawing.py",
                 "report/lead", "cli/results/_warnings.py", "cli/results/compare.py")
#: The ``log.warning`` calls left in them, each with why it is no result's warning.
OPERATIONAL_WARNINGS = {
    "canlog/decode_table.py": "evtribo decode's console: a log's decoder warnings, once for "
                              "the whole log, in no result",
    "session/check.py": "a session's check that could not be made: said to the operator, "
                        "about no result",
    "report/study_report.py": "the report running compare for a folder without a fit",
    "report/study_files.py": "what the report could not read of the study folder (its rig, "
                             "the sidecars' notes) for its own page",
    "figures/registry/catalogue.py": "a lab's figure plug-in refused (an unknown section, a "
                                     "kind registered twice): about the installation, no "
                                     "result",
}
#: Modules among those sites whose notes are no result's warnings, each with why.
NOT_RESULTS = {
    "population/plan.py": "evtribo plan's notes on a simulated design (how its expected "
                          "intervals were computed), about no result",
}
#: The callables whose first argument is a warning kind's id.
_SAYS = {"emit", "Note", "_kept", "record"}


def _kind_ids(node: ast.expr) -> list[str]:
    """The literal ids an argument can be (``"a" if x else "b"``: both)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, ast.IfExp):
        return _kind_ids(node.body) + _kind_ids(node.orelse)
    return []


def _warning_site_files() -> list[Path]:
    out = []
    for part in WARNING_SITES:
        path = SRC / part
        out += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return [p for p in out if p.relative_to(SRC).as_posix() not in NOT_RESULTS]


def _said_list(node: ast.expr) -> bool:
    """Whether an expression is a list of warnings or notes (``notes``, ``rows.notes``)."""
    name = node.id if isinstance(node, ast.Name) else \
        node.attr if isinstance(node, ast.Attribute) else ""
    return name in ("warnings", "notes", "said")


def _text(node: ast.expr) -> bool:
    """Whether an expression is a sentence made here (a string, an f-string, strings added)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return True
    if isinstance(node, ast.JoinedStr):
        return True
    if isinstance(node, ast.BinOp):
        return _text(node.left) or _text(node.right)
    if isinstance(node, ast.List | ast.ListComp):
        elts = node.elts if isinstance(node, ast.List) else [node.elt]
        return any(_text(e) for e in elts)
    return False


def test_every_warning_is_a_record_of_a_kind_the_catalogue_holds():
    """Every literal id handed to ``emit`` (or kept as a ``Note``) is a kind of the
    catalogue; no ``log.warning`` (but the operational ones listed, each with its reason),
    and no sentence appended to a list of warnings or notes, is left where the analysis's
    warnings are said."""
    from evtribo.warning.catalogue import KINDS

    unknown, logged, appended = [], [], []
    for path in _warning_site_files():
        rel = path.relative_to(SRC).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call):
                func = node.func
                name = func.id if isinstance(func, ast.Name) else \
                    func.attr if isinstance(func, ast.Attribute) else ""
                if name in _SAYS and node.args:
                    unknown += [f"{rel}:{node.lineno}: {k}" for k in _kind_ids(node.args[0])
                                if k not in KINDS]
                if name == "warning" and isinstance(func, ast.Attribute) \
                        and rel not in OPERATIONAL_WARNINGS:
                    logged.append(f"{rel}:{node.lineno}")
                if name in ("append", "extend", "insert") and isinstance(func, ast.Attribute) \
                        and _said_list(func.value) and node.args \
                        and any(_text(a) for a in node.args):
                    appended.append(f"{rel}:{node.lineno}")
            if isinstance(node, ast.AugAssign) and _said_list(node.target) \
                    and _text(node.value):
                appended.append(f"{rel}:{node.lineno}")
    assert not unknown, f"ids no kind of the catalogue has: {unknown}"
    assert not logged, f"warnings logged, not emitted: {logged}"
    assert not appended, f"sentences kept as warnings, not emitted: {appended}"


def test_the_structure_check_of_warnings_finds_what_it_looks_for():
    """The check above looks where the warnings are said (it finds the emitters)."""
    said = sum(path.read_text(encoding="utf-8").count("emit(")
               for path in _warning_site_files())
    assert said >= 80


def _how_to_add() -> dict[str, list[str]]:
    """The rows of docs/architecture.md's "How to add": what is added, and its cells."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    section = text.split("## How to add", 1)[1].split("\n## ", 1)[0]
    rows = [line.strip("|").split(" | ") for line in section.splitlines()
            if line.startswith("| a ")]
    return {cells[0].strip(): [c.strip() for c in cells[1:]] for cells in rows}


def test_every_way_to_add_architecture_md_gives_is_there():
    """docs/architecture.md's "How to add" names, for a log format, a friction law, a
    population model, a figure and a warning, the files to touch (each there: a module, or
    the folder a new one goes into), a registry that imports (a mapping of what is
    registered) and the entry point group its module reads plug-ins from."""
    import importlib
    import importlib.util
    from collections.abc import Mapping

    rows = _how_to_add()
    assert set(rows) == {"a log format", "a friction law", "a population model", "a figure",
                         "a warning"}
    wrong = []
    for what, cells in rows.items():
        for code in re.findall(r"`([^`]+)`", " ".join(cells)):
            if "<" in code and "/" in code:  # the folder a new module goes into
                if not (SRC / code).parent.is_dir():
                    wrong.append(f"{what}: no folder for {code}")
            elif code.endswith((".py", ".md")) and \
                    not any((base / code).exists() for base in (SRC, ROOT)):
                wrong.append(f"{what}: no {code}")
        module_path, registry = re.search(r"`([\w/]+\.py)` \(`(\w+)`", cells[1]).groups()
        parts = Path(module_path).with_suffix("").parts
        module = importlib.import_module(".".join(
            ("evtribo", *(parts[:-1] if parts[-1] == "__init__" else parts))))
        if not isinstance(getattr(module, registry, None), Mapping | tuple):
            wrong.append(f"{what}: {module_path} has no registry {registry}")
        group = re.search(r"entry point group (evtribo\.\w+)", cells[2]).group(1)
        near = (module.__name__, module.__name__.rsplit(".", 1)[0] + ".catalogue")
        groups = {vars(importlib.import_module(m)).get("ENTRY_POINTS") for m in near
                  if importlib.util.find_spec(m) is not None}
        if group not in groups:
            wrong.append(f"{what}: {module_path} reads no entry point group {group}")
    assert not wrong, "\n".join(wrong)
