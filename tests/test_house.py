"""The house rules of ``src/flexmb`` (issue #21): small modules, short functions, no import cycles.

Every module is at most ``MAX_MODULE_LINES`` lines and every function at
most ``MAX_FUNCTION_LINES`` lines of code: its ``def`` line to its last
line, without its docstring (a public function's numpy docstring, with its
parameters, returns and examples, documents it and is not what makes a
function hard to read). The modules import each other without cycles: the
graph of every ``import`` statement (those inside functions too) between
flexmb's modules has no strongly connected component of more than one
module. What is over a limit today, or in a cycle, is listed below with the
reason; the lists only shrink: an entry that is no longer over its limit, or
a cycle that is gone or has changed, fails the test until it is taken off
(or updated to the smaller cycle).
"""

from __future__ import annotations

import ast
import pathlib

import pytest

import flexmb

PACKAGE = pathlib.Path(flexmb.__file__).parent
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80

#: modules over MAX_MODULE_LINES (none left: an entry here must say why the module cannot be split)
LONG_MODULES: set[str] = set()

#: functions over MAX_FUNCTION_LINES, as "module path:qualified name" (none left: an entry must say why)
LONG_FUNCTIONS: set[str] = set()

#: import cycles among flexmb's modules (strongly connected components), each a set of module names
IMPORT_CYCLES: set[frozenset[str]] = set()

#: cycles among flexmb's packages and top-level modules (``flexmb.scene``, ``flexmb.result``, ...), with
#: the reason each may stay: Result's convenience methods (``export_vtk``, ``plot``, ``show``) import
#: export and viz when called, as pyvista's ``mesh.plot()`` does (STYLE.md), while
#: ``export.snapshots`` builds a Result of the states it writes
PACKAGE_CYCLES: set[frozenset[str]] = {frozenset({"flexmb.export", "flexmb.result", "flexmb.viz"})}


def _modules():
    return sorted(PACKAGE.rglob("*.py"))


def _rel(path: pathlib.Path) -> str:
    return path.relative_to(PACKAGE).as_posix()


def _module_name(path: pathlib.Path) -> str:
    parts = ("flexmb",) + path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _docstring_lines(node) -> int:
    """Lines of a function's docstring (0 without one)."""
    first = node.body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
        return first.end_lineno - first.lineno + 1
    return 0


def _functions(tree):
    """``(qualified name, lines)`` of every function and method, nested ones too."""
    def walk(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                yield name, child.end_lineno - child.lineno + 1 - _docstring_lines(child)
                yield from walk(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                yield from walk(child, prefix + child.name + ".")
            else:
                yield from walk(child, prefix)

    yield from walk(tree, "")


def _sizes():
    modules, functions = {}, {}
    for path in _modules():
        text = path.read_text(encoding="utf-8")
        modules[_rel(path)] = len(text.splitlines())
        for name, lines in _functions(ast.parse(text)):
            functions[f"{_rel(path)}:{name}"] = lines
    return modules, functions


def test_no_module_is_too_long():
    modules, _ = _sizes()
    over = {m for m, n in modules.items() if n > MAX_MODULE_LINES}
    assert over - LONG_MODULES == set(), {m: modules[m] for m in over - LONG_MODULES}
    # the allow-list only shrinks: take a module off once it is within the limit
    assert LONG_MODULES - over == set(), {m: modules.get(m) for m in LONG_MODULES - over}


def test_no_function_is_too_long():
    _, functions = _sizes()
    over = {f for f, n in functions.items() if n > MAX_FUNCTION_LINES}
    assert over - LONG_FUNCTIONS == set(), {f: functions[f] for f in over - LONG_FUNCTIONS}
    assert LONG_FUNCTIONS - over == set(), {f: functions.get(f) for f in LONG_FUNCTIONS - over}


def _imports(path: pathlib.Path, names: set[str]) -> set[str]:
    """flexmb modules imported anywhere in a module (function-level imports too)."""
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            # ``from pkg import mod`` imports the module pkg.mod, ``from mod import name`` the module mod
            targets = [f"{module}.{a.name}" if f"{module}.{a.name}" in names else module for a in node.names]
        else:
            continue
        for target in targets:
            while target and target not in names:  # ``import flexmb.a.b`` where b is a name: the module a
                target = target.rpartition(".")[0]
            if target and target != me:
                found.add(target)
    return found


def _graph() -> dict[str, set[str]]:
    paths = {_module_name(p): p for p in _modules()}
    names = set(paths)
    return {name: _imports(path, names) for name, path in paths.items()}


def _cycles(graph: dict[str, set[str]]) -> set[frozenset[str]]:
    """Strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index, low, on_stack, stack, out = {}, {}, set(), [], set()
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                if len(component) > 1:
                    out.add(frozenset(component))
    return out


def test_the_cycle_finder_finds_cycles():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"e"}}
    assert _cycles(graph) == {frozenset("abc")}


def test_the_import_graph_sees_relative_and_function_level_imports():
    graph = _graph()
    assert "flexmb.scene.loader" in graph["flexmb.scene.load"]  # from .loader import _Loader
    assert "flexmb.scene.metrics" in graph["flexmb.scene.outputs"]  # inside run_summary
    assert "flexmb.memory" in graph["flexmb.scene.loader"]  # from .. import memory, registry


def test_no_import_cycles():
    found = _cycles(_graph())
    assert found - IMPORT_CYCLES == set(), sorted(sorted(c) for c in found - IMPORT_CYCLES)
    # the allow-list only shrinks: take a cycle off (or update it) once it is broken
    assert IMPORT_CYCLES - found == set(), sorted(sorted(c) for c in IMPORT_CYCLES - found)


def _package(module: str) -> str:
    """The unit of the package graph: a subpackage (``flexmb.scene``) or a top-level module (``flexmb.result``)."""
    return ".".join(module.split(".")[:2])


def test_no_package_cycles_but_the_listed_ones():
    graph: dict[str, set[str]] = {}
    for module, imported in _graph().items():
        unit = _package(module)
        graph.setdefault(unit, set()).update(_package(m) for m in imported if _package(m) != unit)
    found = _cycles(graph)
    assert found - PACKAGE_CYCLES == set(), sorted(sorted(c) for c in found - PACKAGE_CYCLES)
    assert PACKAGE_CYCLES - found == set(), sorted(sorted(c) for c in PACKAGE_CYCLES - found)


def test_a_scene_does_not_depend_on_studies():
    # studies run scenes; a scene's metrics are its own (scene.metrics)
    assert not any(_package(m) == "flexmb.study" for name, imported in _graph().items()
                   if name.startswith("flexmb.scene") for m in imported)


@pytest.mark.parametrize("rule", ["modules", "functions"])
def test_allow_lists_name_existing_code(rule):
    modules, functions = _sizes()
    listed, known = (LONG_MODULES, modules) if rule == "modules" else (LONG_FUNCTIONS, functions)
    assert listed <= set(known)
