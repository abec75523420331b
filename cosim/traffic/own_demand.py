"""The user's own SUMO demand: route, flow and vType files used as they are
(`[traffic] routes`) or a `.sumocfg`'s input files (`[road] sumocfg`), read and checked
before SUMO starts.

SUMO itself finds a missing file, a route over an edge the network lacks or an id given
twice only when it loads that part of the demand (at its start, or minutes into the run
for a vehicle that departs late: `--route-steps`), and then stops the whole simulation.
So every file is read here first (ElementTree, bounded in size) and each problem is one
InputError line naming the scenario, the key, the value and what is allowed:

- the file exists, is XML, and its root is SUMO's `<routes>` or `<additional>` (or
  `<add>`, which older SUMO files use and SUMO still reads);
- every edge a route, trip or flow names (`edges`, `from`, `to`, `via`) is an edge of
  the network; every `route` and `type` a vehicle or flow refers to is defined in the
  files (or is one of SUMO's default types);
- no id clashes with cosim's own (`check_demand`): the SV (`sv`), the scenario's
  scripted TVs, cosim's vTypes (`tv`, `sv`, `sv_*`, `tv_scripted*`, `driven_*`) and its
  routes (`highway_route`, `highway_route@*`). A file may redefine SUMO's
  `DEFAULT_VEHTYPE` (a vType or a vTypeDistribution, as SUMO's shipped scenarios do):
  cosim's own types are copies of its own `cosim_base` (cosim.traffic.process).

Then SUMO itself loads the whole demand once, without running a step (`dry_load`:
`--route-steps 0`, cached per files as they stand), and its first error is the line:
what only SUMO knows (attribute values, a negative length, ...).

From a `.sumocfg` (`read_sumocfg`) only the input files are read: `net-file`,
`route-files`, `additional-files`, relative to the `.sumocfg` as SUMO resolves them; every
other option in it is ignored (README "Running cosim in your own SUMO scenario" says why).

Every file is read through one reader (`sumo_file_bytes`), gzipped or not, as SUMO reads
it. SUMO never reads the user's route and additional files themselves: it gets copies in
the run's temporary folder (`sumo_file_options`, for the run and the dry load alike),
each holding the file's demand only (`copy_for_sumo`): detectors, edge data and every
other element that would write a file of its own are left out, and the output files of
the devices a vType or vehicle asks for (`device.ssm.file`, `device.toc.file`, SSM's
default `ssm_<id>.xml`) go into that temporary folder, deleted with it. A file that
includes another (`<include href>`) is refused: the copy would leave the included file
out.
"""

from __future__ import annotations

import functools
import gzip
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from cosim.errors import InputError
from cosim.validation import not_a_file, not_utf8

MAX_DEMAND_BYTES = 64 * 2**20  # a route file of a motorway study is kB to a few MB
GZIP_MAGIC = b"\x1f\x8b"  # the first bytes of a gzip file
# SUMO builds every vehicle of a flow when it loads the demand (~3 kB each): a flow of
# 10^9 vehicles fills the memory before the first step. 200 000 is two days of a full
# three-lane motorway (2000 veh/h/lane): no run of cosim inserts that many.
MAX_FLOW_VEHICLES = 200_000
FLOW_END_DEFAULT = 86400.0  # s, a flow's end when it gives none (SUMO's default)
DRY_LOAD_SECONDS = 120.0  # s, the validating SUMO's time (a motorway demand loads in ~1 s)
DRY_LOAD_BYTES = 4 * 2**30  # its address space (it needs ~0.2 GiB for a motorway demand)
# s, where SUMO ends a flow that gives no end when the simulation has none (the run's)
RUN_FLOW_END = "86400"
FLOW_TAGS = ("flow", "personFlow", "containerFlow")
FLOW_RATES = frozenset({"period", "vehsPerHour", "probability", "perHour"})
ROOTS = ("routes", "additional", "add")  # what SUMO reads as route or additional files
VEHICLE_TAGS = ("vehicle", "trip", "flow")  # what enters the road as a car-like vehicle
PERSON_TAGS = ("person", "personFlow", "container", "containerFlow")
# SUMO's built-in vTypes: a vehicle may name them without defining them
SUMO_TYPES = ("DEFAULT_VEHTYPE", "DEFAULT_PEDTYPE", "DEFAULT_BIKETYPE",
              "DEFAULT_CONTAINERTYPE", "DEFAULT_TAXITYPE", "DEFAULT_RAILTYPE")
# cosim's own SUMO ids (cosim.traffic.sumo, .route, .traffic_vehicles, cosim.run.observer)
COSIM_TYPES = re.compile(r"tv|sv|sv_.*|tv_scripted.*|driven_.*|cosim_base")
COSIM_ROUTES = re.compile(r"highway_route(@.*)?")
COSIM_VEHICLES = ("sv",)
# the .sumocfg options read (long name and SUMO's short synonym)
CFG_NET = ("net-file", "n")
CFG_ROUTES = ("route-files", "r")
CFG_ADDITIONAL = ("additional-files", "a")


@dataclass(frozen=True)
class OwnDemand:
    """The user's demand as SUMO gets it (absolute paths) and the warm-up before the SV."""

    # --route-files, in order: [road] sumocfg's, then [traffic] routes
    route_files: tuple[Path, ...]
    additional_files: tuple[Path, ...]  # --additional-files (a .sumocfg's)
    warmup: float  # s, SUMO runs the demand alone this long before the SV enters


@dataclass(frozen=True)
class SumoConfig:
    """The input files a `.sumocfg` names, resolved relative to it."""

    path: Path
    net_file: Path
    route_files: tuple[Path, ...]
    additional_files: tuple[Path, ...]


def _file_problem(path: Path) -> str | None:
    """Why `path` is not a readable demand file of at most MAX_DEMAND_BYTES (None: it is)."""
    problem = not_a_file(path)
    if problem is not None:
        return f"not found: {path}" if problem == "not found" else f"{path} is {problem}"
    problem = not_utf8(path)
    if problem is not None:
        return f"SUMO cannot open {path}: {problem}"
    size = path.stat().st_size
    if size > MAX_DEMAND_BYTES:
        return f"{path} has {size} bytes, at most {MAX_DEMAND_BYTES // 2**20} MiB allowed"
    return None


def sumo_file_bytes(path: Path, limit: int = MAX_DEMAND_BYTES) -> bytes:
    """The XML of a file SUMO reads, unpacked if it is gzipped: SUMO tells gzip by the
    file's first bytes, whatever its name (a name ending .gz must be gzip all the same).
    At most `limit` bytes once unpacked; OSError, EOFError or ValueError otherwise."""
    with open(path, "rb") as fh:
        packed = fh.read(len(GZIP_MAGIC)) == GZIP_MAGIC
    if packed or path.suffix == ".gz":
        with gzip.open(path, "rb") as stream:
            data = stream.read(limit + 1)
    else:
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    if len(data) > limit:
        raise ValueError(f"more than {limit // 2**20} MiB of XML")
    return data


def _parse(source: str, key: str, written: str, path: Path, what: str) -> ET.Element:
    """The XML root of a file the scenario names, or InputError (one line)."""
    problem = _file_problem(path)
    if problem is not None:
        raise InputError(source, key, written, f"an existing {what} ({problem})")
    try:
        return ET.fromstring(sumo_file_bytes(path))
    except (ET.ParseError, OSError, EOFError, ValueError) as exc:
        raise InputError(source, key, written,
                         f"a {what} in XML ({path.name}: {exc})") from None


def _file_list(value: str, base: Path) -> tuple[Path, ...]:
    """SUMO's comma-separated file list, each relative to `base` unless absolute."""
    names = [n.strip() for n in value.split(",") if n.strip()]
    return tuple((base / n).resolve() for n in names)  # as SUMO: no ~ expansion


def read_sumocfg(source: str, key: str, written: str, path: Path) -> SumoConfig:
    """The net, route and additional files of a `.sumocfg` (InputError naming `key` if it
    is missing, not XML, not a SUMO configuration, or names no net-file or a missing one)."""
    root = _parse(source, key, written, path, "SUMO configuration file (.sumocfg)")
    if root.tag not in ("configuration", "sumoConfiguration"):
        raise InputError(source, key, written,
                         f"a SUMO configuration file (<configuration> root; {path.name} "
                         f"has <{root.tag}>)")
    found: dict[str, str] = {}
    for element in root.iter():
        for names in (CFG_NET, CFG_ROUTES, CFG_ADDITIONAL):
            if element.tag in names and "value" in element.attrib:
                found[names[0]] = element.attrib["value"]
    base = path.parent
    nets = _file_list(found.get("net-file", ""), base)
    if len(nets) != 1:
        raise InputError(source, key, written,
                         f"a .sumocfg naming one net-file ({path.name} names "
                         f"{len(nets) or 'none'})")
    problem = _file_problem(nets[0])
    if problem is not None:
        raise InputError(source, key, written,
                         f"a .sumocfg whose net-file exists ({path.name}: net-file "
                         f"{found['net-file']!r}: {problem})")
    return SumoConfig(path=path, net_file=nets[0],
                      route_files=_file_list(found.get("route-files", ""), base),
                      additional_files=_file_list(found.get("additional-files", ""), base))


@dataclass
class _Seen:
    """What the demand files define and refer to, gathered over all of them."""

    types: set[str]
    routes: set[str]
    vehicles: dict[str, str]  # vehicle / trip / flow / person id -> its tag
    refs: list[tuple[str, str, str, str]]  # (file key, what refers, "route"/"type", id)


@dataclass(frozen=True)
class _Rules:
    """What every demand file is checked against."""

    source: str  # the scenario (InputError's source)
    net_edges: set[str]  # the network's edge ids
    net_name: str  # the network's file name
    reserved: set[str]  # vehicle ids cosim uses (the SV, the scripted TVs)


def check_demand(source: str, files: Sequence[tuple[str, str, Path]], net_edges: set[str],
                 net_name: str, scripted: Iterable[str]) -> list[tuple[str, str, ET.Element]]:
    """Read every demand file (`(key, written value, path)`, keys like
    `traffic.routes[0]`) and raise InputError on the first fault (module docstring).
    Returns what was read, `(key, file name, XML root)` per file, for the departures'
    check (cosim.traffic.departures)."""
    seen = _Seen(types=set(SUMO_TYPES), routes=set(), vehicles={}, refs=[])
    rules = _Rules(source, net_edges, net_name, set(COSIM_VEHICLES) | set(scripted))
    read: list[tuple[str, str, ET.Element]] = []
    for key, written, path in files:
        root = _parse(source, key, written, path, "SUMO route file")
        if root.tag not in ROOTS:
            raise InputError(source, key, written,
                             f"a SUMO route or additional file (<routes> or <additional> "
                             f"root; {path.name} has <{root.tag}>)")
        _read_file(rules, key, path.name, written, root, seen)
        read.append((key, path.name, root))
    for key, who, kind, ref in seen.refs:
        known = seen.routes if kind == "route" else seen.types
        if ref not in known:
            raise InputError(source, key, f"{who} {kind}={ref!r}",
                             f"a {'route' if kind == 'route' else 'vType'} defined in the "
                             "demand files" + ("" if kind == "route" else
                                               " or one of SUMO's DEFAULT_* types"))
    return read


def _read_file(rules: _Rules, key: str, name: str, written: str, root: ET.Element,
               seen: _Seen) -> None:
    """One demand file's definitions and references into `seen` (file `name`, given as
    `written` under `key`); InputError on a fault (module docstring)."""
    source, net_edges, net_name, reserved = (rules.source, rules.net_edges, rules.net_name,
                                             rules.reserved)

    def clash(what: str, ident: str, allowed: str) -> InputError:
        return InputError(source, key, f"{name}: {what} id={ident!r}", allowed)

    def edges(who: str, attr: str, value: str) -> None:
        for edge in value.split():
            if edge not in net_edges:
                raise InputError(source, key, f"{name}: {who} {attr}={edge!r}",
                                 f"edges of the network {net_name}")

    for element, parent in _walk(root, None):
        tag, attrib = element.tag, element.attrib
        ident = attrib.get("id", "")
        if tag == "include":
            raise InputError(source, key, f"{name}: <include href={attrib.get('href', '')!r}>",
                             "a file without <include> (SUMO gets a copy of each file, "
                             "which would leave the included one out): list that file "
                             "in traffic.routes instead")
        if tag in ("vType", "vTypeDistribution"):
            if COSIM_TYPES.fullmatch(ident):
                raise clash(tag, ident, "a vType id cosim does not use (cosim's are tv, sv, "
                            "sv_*, tv_scripted*, driven_*, cosim_base)")
            seen.types.add(ident)
            for member in attrib.get("vTypes", "").split():
                seen.refs.append((key, f"{name}: {tag} {ident!r}", "type", member))
        elif tag in ("route", "routeDistribution"):
            if ident and COSIM_ROUTES.fullmatch(ident):
                raise clash(tag, ident, "a route id cosim does not use (cosim's are "
                            "highway_route, highway_route@*)")
            who = (f"{tag} {ident!r}" if ident or parent is None
                   else f"the route of {parent.tag} {parent.attrib.get('id', '')!r}")
            edges(who, "edges", attrib.get("edges", ""))
            if ident:
                seen.routes.add(ident)
        elif tag in VEHICLE_TAGS or tag in PERSON_TAGS:
            if ident in reserved:
                raise clash(tag, ident, "a vehicle id cosim does not use (cosim's SV is 'sv', "
                            "its scripted TVs are the [[tv]] ids)")
            if tag == "flow" and any(re.fullmatch(re.escape(ident) + r"\.\d+", r)
                                     for r in reserved):
                raise clash(tag, ident, "a flow whose vehicles (id.0, id.1, ...) do not take "
                            "the id of cosim's SV or a [[tv]]")
            if ident in seen.vehicles:
                raise clash(tag, ident, "ids given once across the demand files")
            seen.vehicles[ident] = tag
            who = f"{tag} {ident!r}"
            size = flow_size(attrib) if tag.lower().endswith("flow") else None
            if size is not None and size[0] > MAX_FLOW_VEHICLES:
                raise InputError(source, key, f"{name}: {who} {size[1]}",
                                 f"a flow of at most {MAX_FLOW_VEHICLES} vehicles (this one "
                                 f"has {size[0]:.0f}; SUMO builds every vehicle of a flow "
                                 "when it loads the demand)")
            for attr in ("from", "to", "via"):
                if attr in attrib:
                    edges(who, attr, attrib[attr])
            if "route" in attrib and tag in VEHICLE_TAGS:
                seen.refs.append((key, f"{name}: {who}", "route", attrib["route"]))
            if "type" in attrib:
                seen.refs.append((key, f"{name}: {who}", "type", attrib["type"]))


RATES = (("vehsPerHour", 3600.0), ("personsPerHour", 3600.0), ("containersPerHour", 3600.0))


def flow_size(attrib: dict[str, str]) -> tuple[float, str] | None:
    """How many vehicles (persons) a flow inserts over its whole interval, and the
    attributes that say so (None: not plain numbers; SUMO's own load judges those)."""
    try:
        if "number" in attrib:
            return float(attrib["number"]), f"number={attrib['number']}"
        begin = float(attrib.get("begin", "0"))
        span = max(float(attrib.get("end", FLOW_END_DEFAULT)) - begin, 0.0)
        over = f"from begin={begin:g} to end={begin + span:g} s"
        for name, per in RATES:
            if name in attrib:
                return float(attrib[name]) * span / per, f"{name}={attrib[name]} {over}"
        if "period" in attrib:
            period = attrib["period"]
            if period.startswith("exp(") and period.endswith(")"):  # Poisson: mean rate
                return float(period[4:-1]) * span, f"period={period} {over}"
            return span / float(period), f"period={period} {over}"
        if "probability" in attrib:  # at most one vehicle a second
            return float(attrib["probability"]) * span, \
                f"probability={attrib['probability']} {over}"
    except (ValueError, ZeroDivisionError):
        return None
    return None


DEMAND_TAGS = ("vType", "vTypeDistribution", "route", "routeDistribution", *VEHICLE_TAGS,
               *PERSON_TAGS)
INTERVAL = "interval"  # a route file's <interval begin end> around flows: kept, its demand
# the <param> keys by which a vType or vehicle names a device's output file (SUMO's
# device.ssm.file, device.toc.file; any device's *.file or *.output)
DEVICE_OUTPUT = re.compile(r"device\.[^.]+\.(.+\.)?(file|output)")
# SSM's output for an equipped vehicle without a file of its own: `ssm_<id>.xml` in the
# working directory unless this option names one
SSM_DEFAULT_OPTION = "--device.ssm.file"
READ_RELATIVE = ("imgFile", "osgFile")  # files a vType reads, relative to its file


def copy_for_sumo(path: Path, out_dir: Path, flow_end: str | None = None) -> Path:
    """A copy of a user's route or additional file in `out_dir` (the run's temporary
    folder) holding only its demand: the root's DEMAND_TAGS children (and <interval>s of
    them), so detectors, edge or lane data, calibrators, rerouters, speed signs and TLS
    programs are left out (they write files of their own, shared by a batch's workers
    and outside the output folder, or are the network's business, not the demand's).
    Device output files named in it (DEVICE_OUTPUT params) are redirected into `out_dir`,
    and the files a vType reads (READ_RELATIVE) keep pointing at the user's folder.
    `flow_end` (s, the dry load's): the end of each flow outside an <interval> that
    leaves its end to the simulation's (no `end`, and not both `number` and a rate)."""
    root = ET.fromstring(sumo_file_bytes(path))
    kept = ET.Element(root.tag, dict(root.attrib))
    for child in root:
        if child.tag in DEMAND_TAGS:
            kept.append(child)
        elif child.tag == INTERVAL:
            interval = ET.SubElement(kept, INTERVAL, dict(child.attrib))
            interval.extend(c for c in child if c.tag in DEMAND_TAGS)
    if flow_end is not None:
        for flow in kept:
            if (flow.tag in FLOW_TAGS and "end" not in flow.attrib
                    and not ("number" in flow.attrib and FLOW_RATES & flow.attrib.keys())):
                flow.set("end", flow_end)
    index = len(list(out_dir.iterdir()))
    for element in kept.iter():
        if element.tag == "param" and DEVICE_OUTPUT.fullmatch(element.get("key", "")):
            element.set("value", str(out_dir / f"device_{index}_{element.get('key')}.xml"))
        for attr in READ_RELATIVE:
            if element.get(attr) and not Path(element.get(attr, "")).is_absolute():
                element.set(attr, str((path.parent / element.get(attr, "")).resolve()))
    name = path.name.removesuffix(".gz").replace(",", "_")  # SUMO splits file lists at ","
    out = out_dir / f"sumo_{index}_{name}"
    ET.ElementTree(kept).write(out, encoding="utf-8", xml_declaration=True)
    return out


def sumo_file_options(route_files: Sequence[Path], additional_files: Sequence[Path],
                      out_dir: Path, flow_end: str | None = None) -> list[tuple[str, str]]:
    """The SUMO options that give it the user's files: copies of them in `out_dir`
    (`copy_for_sumo`, with `flow_end`), and SSM's default output file there too. The one
    way the user's route and additional files reach SUMO (the run and the dry load)."""
    options = []
    if route_files:
        options.append(("--route-files", ",".join(
            str(copy_for_sumo(p, out_dir, flow_end)) for p in route_files)))
    if additional_files:
        options.append(("--additional-files", ",".join(
            str(copy_for_sumo(p, out_dir, flow_end)) for p in additional_files)))
    if options:
        options.append((SSM_DEFAULT_OPTION, str(out_dir / "device_ssm.xml")))
    return options


def dry_load(source: str, key: str, value: object, network: Path,
             route_files: Sequence[Path], additional_files: Sequence[Path]) -> None:
    """SUMO itself loads the demand (all of it at once: `--route-steps 0`) on the network
    and runs no step; InputError with SUMO's first error if it refuses (what the checks
    above do not know: attribute values, distributions, ...). Cached per files as they
    stand."""
    stamp = tuple((str(p), *_stamp(p)) for p in (network, *route_files, *additional_files))
    error = _dry_load(stamp, len(route_files))
    if error:
        raise InputError(source, key, value,
                         f"demand files SUMO loads without an error (SUMO says: {error})")


def _stamp(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_mtime_ns, st.st_size


@functools.lru_cache(maxsize=16)
def _dry_load(stamp: tuple[tuple[str, int, int], ...], n_routes: int) -> str:
    """SUMO's first error line loading the files of `stamp` (network, route files, then
    additional files), "" if none; SUMO bounded in time and memory (DRY_LOAD_SECONDS,
    DRY_LOAD_BYTES) and killed with cosim (cosim.bounded_process)."""
    import tempfile

    from cosim.bounded_process import run_bounded

    paths = [Path(p) for p, _, _ in stamp]
    network, routes, additional = paths[0], paths[1:1 + n_routes], paths[1 + n_routes:]
    binary = "sumo"
    try:
        import sumolib

        binary = sumolib.checkBinary("sumo")
    except (ImportError, SystemExit):
        pass
    with tempfile.TemporaryDirectory(prefix="cosim-demand-") as tmp:
        cmd = [binary, "-n", str(network), "--route-steps", "0", "--begin", "0", "--end", "0",
               "--no-step-log", "true", "--no-warnings", "true",
               "--duration-log.disable", "true"]
        # no step is run (--end 0), but a flow without an end ends at the simulation's:
        # in the run, which sets none, SUMO's 24 h; here it would end at 0, before a
        # later begin (SUMO's game/corridor: "Flow 'W30' ends before its begin time")
        for option, files in sumo_file_options(routes, additional, Path(tmp),
                                               flow_end=RUN_FLOW_END):
            cmd += [option, files]
        try:
            done = run_bounded(cmd, timeout=DRY_LOAD_SECONDS, memory_bytes=DRY_LOAD_BYTES,
                               cwd=tmp)
        except OSError as exc:
            return f"SUMO could not be run ({exc})"
    if done.returncode == 0:
        return ""
    if done.timed_out:
        return (f"it did not finish loading the demand in {DRY_LOAD_SECONDS:g} s; "
                "a demand this large is more than a run can take")
    lines = [ln.strip() for ln in (done.stderr + done.stdout).splitlines() if ln.strip()]
    if any("bad_alloc" in ln for ln in lines):  # its memory cap reached
        return (f"loading the demand took more than {DRY_LOAD_BYTES // 2**30} GiB of memory; "
                "a demand this large is more than a run can take")
    errors = [ln for ln in lines if ln.startswith("Error")] or lines or ["(no message)"]
    return errors[0].removeprefix("Error: ")


def _walk(element: ET.Element, parent: ET.Element | None
          ) -> Iterable[tuple[ET.Element, ET.Element | None]]:
    """Every element below `element` (itself first) with its parent, in document order
    (a stack, not recursion: nesting depth is the file's)."""
    stack = [(element, parent)]
    while stack:
        node, above = stack.pop()
        yield node, above
        stack.extend((child, node) for child in reversed(list(node)))
