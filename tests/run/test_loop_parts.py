"""The co-simulation loop's parts stay small: no class over MAX_LINES lines or
MAX_ATTRIBUTES attributes (instance attributes assigned through `self.` anywhere in
its methods, plus class-level names), read with ast from the sources."""

from __future__ import annotations

import ast
from pathlib import Path

import cosim

PACKAGE = Path(cosim.__file__).resolve().parent
LOOP_PARTS = ("run/loop.py", "run/ego.py", "run/observer.py", "run/recorder.py",
              "run/stop.py", "run/metrics_row.py", "run/result.py",
              "traffic/world.py", "traffic/scripted.py",
              "traffic/sumo.py", "traffic/snapshot.py", "traffic/process.py",
              "traffic/traffic_vehicles.py", "traffic/controlled.py", "traffic/route_lanes.py",
              "driving/manoeuvre.py",
              "driving/following.py", "driving/paper.py", "driving/sumo.py",
              "driving/gap/policy.py")
MAX_LINES = 350
MAX_ATTRIBUTES = 25


def attributes(cls: ast.ClassDef) -> set[str]:
    names: set[str] = set()
    for node in cls.body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.Assign):
            names.update(t.id for t in node.targets if isinstance(t, ast.Name))
    for node in ast.walk(cls):
        targets: list[ast.expr] = []
        if isinstance(node, ast.Assign):
            targets = list(node.targets)
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)):
            targets = [node.target]
        for target in targets:
            for sub in ast.walk(target):
                if (isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name)
                        and sub.value.id == "self"):
                    names.add(sub.attr)
    return names


def classes() -> list[tuple[str, ast.ClassDef]]:
    found = []
    for rel in LOOP_PARTS:
        tree = ast.parse((PACKAGE / rel).read_text(encoding="utf-8"))
        found += [(f"{rel}:{n.name}", n) for n in tree.body if isinstance(n, ast.ClassDef)]
    return found


def test_the_measure_counts_self_attributes() -> None:
    cls = ast.parse("class A:\n    k = 1\n    def f(self):\n        self.a = self.b = 0\n"
                    "        self.c += 1\n        x, self.d = 1, 2\n").body[0]
    assert isinstance(cls, ast.ClassDef)
    assert attributes(cls) == {"k", "a", "b", "c", "d"}


def test_the_loop_parts_are_all_there() -> None:
    names = {name.split(":")[1] for name, _ in classes()}
    assert {"CoSimulation", "World", "PlannedEgo", "SumoDrivenEgo", "PaperPolicy",
            "GapPolicy", "SumoPolicy", "Manoeuvre", "CarFollowing", "Observer", "Recorder",
            "StopRules", "MetricsRow", "ScriptedTraffic", "SumoSim"} <= names


def test_no_class_of_the_loop_is_too_big() -> None:
    too_big = []
    for name, cls in classes():
        lines = (cls.end_lineno or cls.lineno) - cls.lineno + 1
        n_attr = len(attributes(cls))
        if lines > MAX_LINES or n_attr > MAX_ATTRIBUTES:
            too_big.append(f"{name}: {lines} lines, {n_attr} attributes")
    assert not too_big, "; ".join(too_big)
