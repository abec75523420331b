"""The package's import graph has no cycle: every `import` inside cosim, at module
level or inside a function (a deferred import is still a dependency, only a later
one), read with ast from the sources."""

from __future__ import annotations

import ast
from pathlib import Path

import cosim

PACKAGE = Path(cosim.__file__).resolve().parent


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """module -> the cosim modules it imports (`from a import b` counts a.b when that
    is a module, else a; `import a.b` counts a.b), plus the packages that contain it
    The package that contains a module is not an edge of its own: Python puts the package
    in sys.modules before its submodules run, and that implicit import carries no names, so
    it cannot close a harmful cycle (a package re-exporting its submodules would otherwise
    always form one); an explicit import of a package's names does count."""
    files = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    explicit: dict[str, set[str]] = {}
    for name, path in files.items():
        is_pkg = path.name == "__init__.py"
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                if node.level:  # relative: from the module's package
                    base = name.split(".") if is_pkg else name.split(".")[:-1]
                    base = base[: len(base) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    deps.add(sub if sub in files else target)
        explicit[name] = {d for d in deps if d in files and d != name}
    return explicit


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One cycle as a list of modules (first = last), or [] (iterative DFS)."""
    colour: dict[str, int] = dict.fromkeys(graph, 0)  # 0 new, 1 on the stack, 2 done
    for root in sorted(graph):
        if colour[root]:
            continue
        stack = [(root, iter(sorted(graph[root])))]
        path = [root]
        colour[root] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                colour[node] = 2
                stack.pop()
                path.pop()
            elif colour[nxt] == 1:
                return path[path.index(nxt):] + [nxt]
            elif colour[nxt] == 0:
                colour[nxt] = 1
                stack.append((nxt, iter(sorted(graph[nxt]))))
                path.append(nxt)
    return []


def test_the_graph_sees_module_and_function_level_imports() -> None:
    graph = import_graph()
    assert "cosim.traffic.world" in graph["cosim.run.loop"]  # module level
    assert "cosim.traffic.demand" in graph["cosim.bench.cosim"]  # inside a function
    assert "cosim.control.allocation" in graph["cosim.control.closed_loop"]  # relative


def test_a_package_reexporting_its_submodule_is_no_cycle() -> None:
    graph = import_graph()
    assert "cosim.scenario.export" in graph["cosim.scenario"]  # __init__ re-exports it
    assert "cosim.scenario" not in graph["cosim.scenario.export"]  # no implicit edge back


def test_find_cycle_finds_one() -> None:
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_inside_cosim() -> None:
    cycle = find_cycle(import_graph())
    assert not cycle, " -> ".join(cycle)
