"""The layers keep to their boundaries, read with ast from the sources:

- SUMO is reached only inside cosim/traffic/ (the adapter, the world): no other module
  imports libsumo or traci, or reaches an adapter (`.sumo`) or the raw API (`.api`);
  sumolib (SUMO's network-file reader, no simulation) only there and in cosim/road/,
  which reads the network's lanes and connections;
- the planner and the lane-change policies never compare policy names (a policy's
  behaviour comes from its own class and options, cosim.driving.registry)."""

from __future__ import annotations

import ast
from pathlib import Path

import cosim
from cosim.driving.registry import names

PACKAGE = Path(cosim.__file__).resolve().parent
SUMO_MODULES = {"libsumo", "traci", "sumolib"}
SUMO_ATTRIBUTES = {"sumo", "api"}


def sources(*under: str) -> list[Path]:
    return sorted(p for u in under for p in (PACKAGE / u).rglob("*.py"))


def sumo_reaches(tree: ast.AST) -> list[str]:
    """Imports of libsumo / traci and `.sumo` / `.api` attribute accesses in a tree."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [f"import {a.name}" for a in node.names
                      if a.name.split(".")[0] in SUMO_MODULES]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            if node.module.split(".")[0] in SUMO_MODULES:
                found.append(f"from {node.module} import ...")
        elif isinstance(node, ast.Attribute) and node.attr in SUMO_ATTRIBUTES:
            found.append(f".{node.attr} (line {node.lineno})")
    return found


def name_comparisons(tree: ast.AST, policy_names: set[str]) -> list[str]:
    """Comparisons against a policy name (a string constant, alone or in a tuple / list /
    set) or against a `.policy` attribute."""
    def is_name(e: ast.expr) -> bool:
        if isinstance(e, ast.Constant) and isinstance(e.value, str):
            return e.value in policy_names
        if isinstance(e, (ast.Tuple, ast.List, ast.Set)):
            return any(is_name(x) for x in e.elts)
        return isinstance(e, ast.Attribute) and e.attr == "policy"

    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare) and any(
                is_name(e) for e in [node.left, *node.comparators]):
            found.append(f"line {node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.match_case) and isinstance(node.pattern, ast.MatchValue) \
                and is_name(node.pattern.value):
            found.append(f"line {node.pattern.lineno}: case {ast.unparse(node.pattern)}")
    return found


def test_the_scans_find_what_they_look_for() -> None:
    code = ("import libsumo\nfrom traci import vehicle\nworld.sumo.move()\nx = sim.api\n")
    assert len(sumo_reaches(ast.parse(code))) == 4
    assert sumo_reaches(ast.parse("from cosim.traffic.sumo import TrafficSnapshot\n")) == []
    bad = ("a = cfg.policy == 'gap'\nb = name in ('paper', 'x')\nc = trigger != 'decision'\n"
           "match p:\n    case 'sumo':\n        pass\n")
    assert len(name_comparisons(ast.parse(bad), {"paper", "gap", "sumo"})) == 3


def test_only_cosim_traffic_reaches_sumo() -> None:
    bad = []
    for path in sources("."):
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] == "traffic":
            continue
        hits = sumo_reaches(ast.parse(path.read_text("utf-8")))
        if rel.parts[0] == "road":  # reads the network file with sumolib, runs no SUMO
            hits = [h for h in hits if "sumolib" not in h]
        bad += [f"{rel}: {hit}" for hit in hits]
    assert not bad, "; ".join(bad)


def test_the_planner_and_the_policies_never_compare_policy_names() -> None:
    policy_names = set(names())
    assert {"paper", "gap", "sumo"} <= policy_names
    bad = []
    for path in sources("planning", "driving"):
        tree = ast.parse(path.read_text("utf-8"))
        bad += [f"{path.relative_to(PACKAGE)} {hit}"
                for hit in name_comparisons(tree, policy_names)]
    assert not bad, "; ".join(bad)
