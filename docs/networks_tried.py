"""The networks of docs/roads.md "Networks tried", second set: motorways built with SUMO's
own netconvert (plain node / edge / connection XML, an OSM-like import) and netgenerate,
each with a 30 s scenario (seed 1, mu 0.6, 15 veh/km/lane of random traffic, the decision
rule, the gap policy with its re-check; `onoff`, from an on-ramp over an off-ramp, 52 s
behind SUMO's own flows), and scenarios for SUMO's shipped game/corridor and
game/racing:

    python docs/networks_tried.py /tmp/nets            # networks and scenarios there
    cosim run /tmp/nets/scurve.toml --out /tmp/nets-out/scurve      # one of NAMES

The network files stay in the folder (NAME.nod.xml, NAME.edg.xml, NAME.con.xml,
NAME.net.xml; kinks.osm), so each can be read as SUMO's users write theirs."""

from __future__ import annotations

import math
import random
import subprocess
import sys
from pathlib import Path

import sumo

GAME = Path(sumo.__file__).resolve().parent / "tools" / "game"  # SUMO's shipped games
# m/s: 80, 100, 110, 120 km/h
V80, V100, V110, V120 = 22.22, 27.78, 30.56, 33.33


def arc(x0: float, y0: float, h0: float, radius: float, length: float, step: float,
        left: bool = True) -> tuple[list[tuple[float, float]], float]:
    """The vertices every `step` m of a circular arc from (x0, y0) at heading h0 (rad),
    its start left out, and the heading at its end."""
    sign = 1.0 if left else -1.0
    cx, cy = x0 - sign * radius * math.sin(h0), y0 + sign * radius * math.cos(h0)
    pts = []
    for i in range(1, int(round(length / step)) + 1):
        h = h0 + sign * i * step / radius
        pts.append((cx + sign * radius * math.sin(h), cy - sign * radius * math.cos(h)))
    return pts, h0 + sign * length / radius


def shape(pts: list[tuple[float, float]]) -> str:
    return " ".join(f"{x:.2f},{y:.2f}" for x, y in pts)


def nodes(**xy: tuple[float, float]) -> str:
    return "<nodes>" + "".join(f'<node id="{k}" x="{x:.2f}" y="{y:.2f}"/>'
                               for k, (x, y) in xy.items()) + "</nodes>"


def edge(eid: str, a: str, b: str, lanes: int, speed: float, extra: str = "",
         inner: str = "") -> str:
    return (f'<edge id="{eid}" from="{a}" to="{b}" numLanes="{lanes}" speed="{speed}"'
            f"{extra}>{inner}</edge>")


def connections(*links: tuple[str, str, int, int]) -> str:
    return "<connections>" + "".join(
        f'<connection from="{a}" to="{b}" fromLane="{i}" toLane="{j}"/>'
        for a, b, i, j in links) + "</connections>"


def netconvert(out: Path, name: str, nod: str, edg: str, con: str = "") -> None:
    (out / f"{name}.nod.xml").write_text(nod, encoding="utf-8")
    (out / f"{name}.edg.xml").write_text("<edges>" + edg + "</edges>", encoding="utf-8")
    cmd = ["netconvert", "-n", f"{name}.nod.xml", "-e", f"{name}.edg.xml",
           "-o", f"{name}.net.xml", "--no-turnarounds", "true"]
    if con:
        (out / f"{name}.con.xml").write_text(con, encoding="utf-8")
        cmd += ["-x", f"{name}.con.xml"]
    subprocess.run(cmd, cwd=out, check=True, capture_output=True)


def build(out: Path) -> None:
    """Every network of NAMES into `out`."""
    # an S-curve without clothoids: R 250 m left 45 degrees, R 250 m right 45, drawn every 10 m
    left, h = arc(500, 0, 0, 250, 250 * math.pi / 4, 10)
    right, _ = arc(*left[-1], h, 250, 250 * math.pi / 4, 10, left=False)
    c, d = left[-1], right[-1]
    netconvert(out, "scurve", nodes(A=(0, 0), B=(500, 0), C=c, D=d, E=(d[0] + 500, d[1])),
               edge("AB", "A", "B", 2, V80)
               + edge("BC", "B", "C", 2, V80, f' shape="{shape([(500, 0), *left])}"')
               + edge("CD", "C", "D", 2, V80, f' shape="{shape([c, *right])}"')
               + edge("DE", "D", "E", 2, V80))
    # a weaving section: ramps drawn straight at 11.3 degrees, the on-ramp's lane runs on
    # 300 m beside the two-lane mainline and leaves as the off-ramp
    netconvert(out, "weave", nodes(A=(0, 0), B=(1000, 0), C=(1300, 0), D=(2500, 0),
                                   R0=(600, -80), R1=(1700, -80)),
               edge("AB", "A", "B", 2, V120) + edge("BC", "B", "C", 3, V120)
               + edge("CD", "C", "D", 2, V120) + edge("on", "R0", "B", 1, V80)
               + edge("off", "C", "R1", 1, V80),
               connections(("on", "BC", 0, 0), ("AB", "BC", 0, 1), ("AB", "BC", 1, 2),
                           ("BC", "off", 0, 0), ("BC", "CD", 1, 0), ("BC", "CD", 2, 1)))
    # an on-ramp, then 500 m on an off-ramp, both drawn straight at 11.3 degrees: the
    # on-ramp's lane runs on as a 250 m acceleration lane that ends; a 250 m deceleration
    # lane begins further on and runs on as the off-ramp (SUMO's game/ramp's layout)
    netconvert(out, "onoff", nodes(A=(0, 0), B=(1000, 0), C=(1250, 0), D=(1750, 0),
                                   E=(2000, 0), F=(3000, 0), R0=(600, -80), R1=(2600, -120)),
               edge("AB", "A", "B", 2, V120) + edge("BC", "B", "C", 3, V120)
               + edge("CD", "C", "D", 2, V120) + edge("DE", "D", "E", 3, V120)
               + edge("EF", "E", "F", 2, V120) + edge("on", "R0", "B", 1, V80)
               + edge("off", "E", "R1", 1, V80),
               connections(("on", "BC", 0, 0), ("AB", "BC", 0, 1), ("AB", "BC", 1, 2),
                           ("BC", "CD", 1, 0), ("BC", "CD", 2, 1), ("CD", "DE", 0, 1),
                           ("CD", "DE", 1, 2), ("DE", "EF", 1, 0), ("DE", "EF", 2, 1),
                           ("DE", "off", 0, 0)))
    # lanes of different widths
    widths = '<lane index="0" width="3.75"/><lane index="1" width="3.5"/>' \
             '<lane index="2" width="3.5"/>'
    netconvert(out, "widths", nodes(A=(0, 0), B=(1500, 0), C=(3000, 0)),
               edge("AB", "A", "B", 3, V120, inner=widths)
               + edge("BC", "B", "C", 3, V120, inner=widths))
    # the speed limit 120 -> 80 -> 120 km/h
    netconvert(out, "speedchange", nodes(A=(0, 0), B=(800, 0), C=(1400, 0), D=(3000, 0)),
               edge("AB", "A", "B", 3, V120) + edge("BC", "B", "C", 3, V80)
               + edge("CD", "C", "D", 3, V120))
    # 40 edges of 60 m, a R 1500 m curve drawn by the nodes themselves (2.3-degree kinks)
    pts = [(i * 60.0, 0.0) for i in range(11)] + [
        (600 + 1500 * math.sin(k * 0.04), 1500 * (1 - math.cos(k * 0.04))) for k in range(1, 31)]
    netconvert(out, "longroute", nodes(**{f"n{i}": p for i, p in enumerate(pts)}),
               "".join(edge(f"e{i}", f"n{i}", f"n{i + 1}", 3, V110) for i in range(40)))
    # 3 -> 2 lanes: netconvert's own connections drop the right lane; given, the left
    ab = nodes(A=(0, 0), B=(1500, 0), C=(3000, 0))
    drop = edge("AB", "A", "B", 3, V120) + edge("BC", "B", "C", 2, V120)
    netconvert(out, "lanedrop", ab, drop)
    netconvert(out, "lanedropl", ab, drop, connections(("AB", "BC", 0, 0), ("AB", "BC", 1, 1)))
    # spreadType="roadCenter", 3 -> 4 -> 3 lanes on a R 1200 m curve drawn every 20 m
    curve, h = arc(1000, 0, 0, 1200, 600, 20)
    b = curve[-1]
    rc = ' spreadType="roadCenter"'
    netconvert(out, "roadcenter", nodes(A=(0, 0), B=(1000, 0), C=b,
                                        D=(b[0] + 1000 * math.cos(h), b[1] + 1000 * math.sin(h))),
               edge("AB", "A", "B", 3, V120, rc)
               + edge("BC", "B", "C", 4, V120, rc + f' shape="{shape([(1000, 0), *curve])}"')
               + edge("CD", "C", "D", 3, V120, rc))
    osm_kinks(out)
    subprocess.run(["netgenerate", "--grid", "--grid.x-number", "12", "--grid.y-number", "1",
                    "--grid.x-length", "250", "-L", "3", "-S", str(V120),
                    "--no-turnarounds", "true", "-o", "grid.net.xml"],
                   cwd=out, check=True, capture_output=True)


def osm_kinks(out: Path) -> None:
    """An OSM motorway of three ways (3 lanes, 120 km/h), a node every 40-80 m turning by
    1-3 degrees either way (seed 7), imported with --geometry.remove."""
    lat0, lon0, earth = 52.5, 13.4, 6378137.0
    rng = random.Random(7)
    x = y = h = 0.0
    pts = [(x, y)]
    while x < 3000:
        step = rng.uniform(40, 80)
        x, y = x + step * math.cos(h), y + step * math.sin(h)
        pts.append((x, y))
        h += math.radians(rng.uniform(1, 3)) * rng.choice((-1, 1))
        h = max(min(h, math.radians(12)), math.radians(-12))
    tags = ('<tag k="highway" v="motorway"/><tag k="lanes" v="3"/>'
            '<tag k="oneway" v="yes"/><tag k="maxspeed" v="120"/>')
    n = len(pts)
    cuts = [1, n // 3, 2 * n // 3, n]
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6">']
    for k, (px, py) in enumerate(pts):
        lat = lat0 + math.degrees(py / earth)
        lon = lon0 + math.degrees(px / (earth * math.cos(math.radians(lat0))))
        lines.append(f'<node id="{k + 1}" lat="{lat:.7f}" lon="{lon:.7f}" version="1"/>')
    for w in range(3):
        refs = "".join(f'<nd ref="{r}"/>' for r in range(cuts[w], cuts[w + 1] + 1))
        lines.append(f'<way id="{500 + w}" version="1">{refs}{tags}</way>')
    (out / "kinks.osm").write_text("\n".join([*lines, "</osm>", ""]), encoding="utf-8")
    subprocess.run(["netconvert", "--osm-files", "kinks.osm", "-o", "kinks.net.xml",
                    "--geometry.remove", "--keep-edges.by-vclass", "passenger",
                    "--output.original-names"], cwd=out, check=True, capture_output=True)


BANDS = [[60, 90], [90, 110], [110, 120]]
# name: (network, route, SV lanes that run through, SV edge, lane, position m, speed km/h)
RUNS: dict[str, tuple[str, list[str], int, str, int, float, float]] = {
    "scurve": ("scurve", ["AB", "BC", "CD", "DE"], 2, "AB", 0, 300, 80),
    "weave": ("weave", ["AB", "BC", "CD"], 2, "AB", 0, 400, 100),
    "weave_on": ("weave", ["on", "BC", "CD"], 2, "on", 0, 100, 80),
    "weave_off": ("weave", ["AB", "BC", "off"], 1, "AB", 1, 600, 100),
    "weave_onoff": ("weave", ["on", "BC", "off"], 1, "on", 0, 100, 80),
    "widths": ("widths", ["AB", "BC"], 3, "AB", 1, 300, 100),
    "speedchange": ("speedchange", ["AB", "BC", "CD"], 3, "AB", 1, 300, 100),
    "longroute": ("longroute", [f"e{i}" for i in range(40)], 3, "e2", 1, 10, 100),
    "kinks": ("kinks", ["500"], 3, "500", 1, 300, 100),
    "lanedrop_right": ("lanedrop", ["AB", "BC"], 2, "AB", 0, 1000, 100),
    "lanedropl": ("lanedropl", ["AB", "BC"], 2, "AB", 2, 1000, 100),
    "roadcenter": ("roadcenter", ["AB", "BC", "CD"], 3, "AB", 1, 500, 100),
    "grid": ("grid", ["A0B0", "B0C0", "C0D0", "D0E0", "E0F0", "F0G0", "G0H0", "H0I0",
                      "I0J0", "J0K0", "K0L0"], 3, "B0C0", 1, 10, 100),
}
NAMES = [*RUNS, "onoff", "corridor", "racing"]


def scenario(name: str, road: str, sv: str, traffic: str, duration: float = 30.0) -> str:
    return (f'[scenario]\nname = "{name}"\nduration_s = {duration}\nstep_s = 0.05\n'
            f"substeps = 10\nseed = 1\n\n[road]\n{road}mu = 0.6\n\n[sv]\n{sv}"
            'plant = "twotrack"\ncontroller = "mimo"\ndecision = true\n\n'
            f'[traffic]\n{traffic}\n[planner]\npolicy = "gap"\nreplanning = true\n')


def scenarios(out: Path) -> None:
    """A scenario per entry of NAMES into `out`."""
    for name, (net, route, through, sv_edge, lane, pos, speed) in RUNS.items():
        vmax = {"scurve": 80, "longroute": 110}.get(name, 120)  # km/h, the network's
        bands = [[min(lo, vmax - 10), min(hi, vmax)] for lo, hi in BANDS]
        bands = bands[:through] if name not in ("weave_off", "weave_onoff") else [[90, 110]]
        length = 700.0 if name == "weave_off" else 1000.0
        (out / f"{name}.toml").write_text(scenario(
            name, f'network = "{net}.net.xml"\nroute = {route}\nlane_speeds_kmh = {bands}\n',
            f'edge = "{sv_edge}"\nlane = {lane}\nposition_m = {pos}\nspeed_kmh = {speed}\n',
            f"density_veh_per_km_lane = 15.0\nlength_m = {length}\n",
            35.0 if name == "weave_off" else 30.0), encoding="utf-8")
    # from the on-ramp over the off-ramp: random traffic would fill the lanes that run
    # through (the deceleration lane's 250 m and the off-ramp), so SUMO's own flows
    (out / "onoff.rou.xml").write_text(
        '<routes><route id="main" edges="AB BC CD DE EF"/><route id="ramp" edges="on BC CD '
        'DE EF"/><flow id="m" route="main" begin="0" vehsPerHour="1800" departLane="random" '
        'departSpeed="max"/><flow id="r" route="ramp" begin="0" vehsPerHour="300" '
        'departSpeed="max"/></routes>', encoding="utf-8")
    (out / "onoff.toml").write_text(scenario(
        "onoff", 'network = "onoff.net.xml"\nroute = ["on", "BC", "CD", "DE", "off"]\n'
        "lane_speeds_kmh = [[60, 80], [90, 110], [110, 120]]\n",
        'edge = "on"\nlane = 0\nposition_m = 200\nspeed_kmh = 80\n',
        'routes = ["onoff.rou.xml"]\nwarmup_s = 60.0\n', 52.0), encoding="utf-8")
    corridor = GAME / "corridor"
    (out / "corridor.toml").write_text(scenario(
        "corridor", f'network = "{corridor / "corridor.net.xml"}"\n'
        "route = ['gneE27', 'gneE25', 'gneE18', 'gneE29']\nlane_speeds_kmh = [[30, 50]]\n",
        'edge = "gneE27"\nlane = 0\nposition_m = 50\nspeed_kmh = 40\n',
        f'routes = ["{corridor / "corridor.rou.xml"}"]\nwarmup_s = 60.0\n'), encoding="utf-8")
    ring = ["172927499#1"] + [f"172927073#{k}" for k in range(6)]
    (out / "racing.toml").write_text(scenario(
        "racing", f'sumocfg = "{GAME / "racing" / "racing.sumocfg"}"\nroute = {ring}\n'
        "lane_speeds_kmh = [[60, 100]]\n",
        'edge = "172927073#0"\nlane = 0\nposition_m = 10\nspeed_kmh = 80\n',
        "warmup_s = 10.0\n"), encoding="utf-8")


if __name__ == "__main__":
    folder = Path(sys.argv[1]).resolve()
    folder.mkdir(parents=True, exist_ok=True)
    build(folder)
    scenarios(folder)
    print(f"wrote {len(NAMES)} scenarios and their networks to {folder}")
