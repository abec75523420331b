"""The SUMO process of one simulation: its command line, starting and closing it, and
the warnings it wrote (cosim.traffic.sumo's lifecycle part).

SUMO is started with `--collision.action warn --collision.mingap-factor 0` (the
default teleport action silently ignores collisions of moved vehicles; a collision is
then a real overlap, not a gap below minGap), `--time-to-teleport -1` (no jam
teleports: every vehicle stays visible to the SV) and `--no-warnings` with an
`--error-log` file: warnings are captured, readable through `warnings()`, and not
printed.

One libsumo simulation per process: a second start silently replaces the first, so
`start` refuses while another simulation is running.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from cosim.errors import SimulationError, check_signals
from cosim.traffic import gui as gui_window
from cosim.traffic.gui import GuiSettings
from cosim.traffic.own_demand import sumo_file_options

BASE_TYPE = "cosim_base"  # the vType cosim's own vTypes are copies of (SUMO's defaults)
# SUMO's ACC and CACC car-following models (SUMO's defaults otherwise): the fleet's
# baselines switch the vehicles they drive to copies of their own vType with one
# (cosim.traffic.takeover.Takeovers.drive_as); a model is chosen only by a file
BASELINE_TYPES = {"ACC": "cosim_acc", "CACC": "cosim_cacc"}
BASE_TYPE_FILE = (f'<additional>\n    <vType id="{BASE_TYPE}"/>\n'
                  + "".join(f'    <vType id="{i}" carFollowModel="{m}"/>\n'
                            for m, i in BASELINE_TYPES.items())
                  + "</additional>\n")

_active: SumoProcess | None = None  # the one running simulation of this process


def _import_api(use_traci: bool) -> ModuleType:
    if use_traci:
        import traci  # sumo-gui needs the socket client; libsumo has no GUI

        return traci
    import libsumo

    return libsumo


@dataclass
class SumoProcess:
    """How SUMO is started for one simulation, and the running API while it is.

    `gui`: sumo-gui's settings (None: headless); `use_traci`: the socket client instead
    of libsumo (always with the GUI)."""

    network: Path  # the .net.xml
    step_length: float  # s
    seed: int
    lanechange_duration: float  # s, 0: instant changes
    sublane: bool
    gui: GuiSettings | None
    use_traci: bool
    extra_args: tuple[str, ...]
    lateral_resolution: float  # m, the sublane model's
    fcd_output: Path | None  # SUMO's --fcd-output (the caller's file)
    # the user's own demand (cosim.traffic.own_demand), loaded with cosim's vehicles
    route_files: tuple[Path, ...] = ()  # --route-files
    additional_files: tuple[Path, ...] = ()  # --additional-files
    # SUMO's detectors along the route (cosim.traffic.detectors): the additional file's
    # text, written into the temporary folder ("": none)
    detectors: str = ""
    # SUMO options of cosim's measures (cosim.traffic.ssm: the SSM device), outputs in
    # folders the caller gives
    measures: tuple[tuple[str, str], ...] = ()
    api: ModuleType | None = None  # while running
    _tmp: tempfile.TemporaryDirectory[str] | None = None
    _log_text: str = ""

    def command(self) -> list[str]:
        """The SUMO command line this simulation starts with (warnings go to a
        temporary log file that lives until close)."""
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="cosim-sumo-")
        binary = "sumo-gui" if self.gui else "sumo"
        try:
            import sumolib

            binary = sumolib.checkBinary(binary)
        except (ImportError, SystemExit):  # sumolib exits if the binary is missing
            pass
        options = [
            ("-n", str(self.network)),
            ("--step-length", repr(self.step_length)),
            ("--seed", str(self.seed)),
            ("--collision.action", "warn"),
            ("--collision.mingap-factor", "0"),
            ("--time-to-teleport", "-1"),
            ("--no-step-log", "true"),
            ("--no-warnings", "true"),
            ("--error-log", str(Path(self._tmp.name) / "sumo-warnings.log")),
            ("--duration-log.disable", "true"),
        ]
        if self.fcd_output is not None:
            options.append(("--fcd-output", str(self.fcd_output)))
        # copies of their files holding their demand only, device outputs redirected
        # into the temporary folder (own_demand.sumo_file_options), after cosim's own
        # base vType (their files may redefine SUMO's DEFAULT_VEHTYPE)
        base = Path(self._tmp.name) / "cosim-types.add.xml"
        base.write_text(BASE_TYPE_FILE, encoding="utf-8")
        theirs = dict(sumo_file_options(self.route_files, self.additional_files,
                                        Path(self._tmp.name)))
        additional = theirs.pop("--additional-files", None)
        files = [str(base)]
        if self.detectors:
            detectors = Path(self._tmp.name) / "cosim-detectors.add.xml"
            detectors.write_text(self.detectors, encoding="utf-8")
            files.append(str(detectors))
        if additional:
            files.append(additional)
        options.append(("--additional-files", ",".join(files)))
        mine = dict(self.measures)
        # cosim's SSM file replaces the default one for their equipped vehicles (SUMO
        # refuses the option twice); their vehicles' encounters then go into it too
        options += [(k, v) for k, v in theirs.items() if k not in mine]
        options += self.measures
        if self.sublane:
            options.append(("--lateral-resolution", repr(self.lateral_resolution)))
        elif self.lanechange_duration > 0:
            options.append(("--lanechange.duration", repr(self.lanechange_duration)))
        if self.gui:
            options += gui_window.options(self.gui)
        # SUMO refuses an option given twice: extra_args replace our defaults
        overridden = {a for a in self.extra_args if a.startswith("-")}
        cmd = [binary]
        for name, value in options:
            if name not in overridden:
                cmd += [name, value]
        return cmd + list(self.extra_args)

    def start(self) -> ModuleType:
        """Start SUMO (the GUI through traci); the API module it runs in."""
        global _active
        if _active is not None and _active is not self and _active.api is not None:
            raise SimulationError(0.0, "another SUMO simulation is running in this process")
        api = _import_api(self.use_traci)
        check_signals()  # a signal that came while cosim loaded: SUMO is not started
        if self.gui:
            gui_window.start(api, self.command())
        else:
            api.start(self.command())
        self.api = api
        _active = self
        check_signals()  # one that came while SUMO started (`close` then ends it)
        return api

    def close(self) -> None:
        """Close SUMO (the GUI as its settings say) and keep the warnings it wrote."""
        global _active
        api = self.api
        if api is None:
            return
        try:
            if self.gui:
                gui_window.close(api, self.gui)
            else:
                api.close()
        finally:
            self.api = None
            _active = None
            if self._tmp is not None:
                self._log_text = self._read_log()
                self._tmp.cleanup()
                self._tmp = None

    def _read_log(self) -> str:
        if self._tmp is None:
            return self._log_text
        log = Path(self._tmp.name) / "sumo-warnings.log"
        try:
            return log.read_text(encoding="utf-8", errors="replace")
        except FileNotFoundError:
            return ""

    def warnings(self) -> list[str]:
        """SUMO's warnings and errors (captured in a log file, not printed).

        SUMO buffers the file: the list is complete once the simulation is closed.
        """
        return [line for line in self._read_log().splitlines() if line.strip()]


@dataclass(frozen=True)
class SumoOptions:
    """How SUMO runs one simulation, beside its network, step and seed."""

    lanechange_duration: float = 3.0  # s, traffic lane changes take this long (0: instant)
    sublane: bool = False  # SUMO's sublane model instead (--lateral-resolution, slower)
    lateral_resolution: float = 0.8  # m, the sublane model's
    gui: bool | GuiSettings = False  # sumo-gui through traci (True: its default settings)
    traci: bool = False  # the headless binary through traci instead of libsumo
    extra_args: tuple[str, ...] = ()  # SUMO options; they replace cosim's of the same name
    fcd_output: Path | None = None  # the file SUMO writes its floating-car data to
    # the user's own demand (cosim.traffic.own_demand, checked before), loaded with
    # cosim's vehicles
    route_files: tuple[Path, ...] = ()  # --route-files
    additional_files: tuple[Path, ...] = ()  # --additional-files
    # SUMO's detectors (cosim.traffic.detectors.DetectorLayout.additional; "": none)
    detectors: str = ""
    # SUMO options of cosim's measures (cosim.traffic.ssm.sumo_options; (): none)
    measures: tuple[tuple[str, str], ...] = ()


def process(network: Path, step: float, seed: int, options: SumoOptions) -> SumoProcess:
    """The process settings of a SumoSim."""
    o = options
    settings = (o.gui if isinstance(o.gui, GuiSettings) else GuiSettings()) if o.gui else None
    return SumoProcess(
        network=Path(network), step_length=float(step), seed=int(seed),
        lanechange_duration=float(o.lanechange_duration), sublane=bool(o.sublane),
        gui=settings, use_traci=bool(o.traci) or settings is not None,
        extra_args=tuple(o.extra_args), lateral_resolution=float(o.lateral_resolution),
        fcd_output=None if o.fcd_output is None else Path(o.fcd_output),
        route_files=tuple(map(Path, o.route_files)),
        additional_files=tuple(map(Path, o.additional_files)), detectors=o.detectors,
        measures=tuple(o.measures))
