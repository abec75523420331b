"""Declarative validation of user tables (scenario files, study files).

Every key of a table is described by one `Field`: its TOML key (which carries
the unit, e.g. `speed_kmh`), the type, the allowed range or choices, the
default, and how to turn the value into SI (`si_divisor`: km/h -> m/s is 3.6).
`validate_table` checks a whole table against its fields in one pass and
raises `InputError` (file, key, value, what is allowed: one line) on the first
problem; unknown keys are rejected with a "did you mean" suggestion.
`declare` puts a Field on a dataclass attribute, so a key is declared once, beside what
it fills (`declared_fields` reads the table back).
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import math
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from cosim.errors import InputError


class _Missing:
    """Sentinel for 'no default: the key is required' and 'the key was not given'."""

    def __repr__(self) -> str:
        return "<missing>"


REQUIRED: Any = _Missing()
SMALLEST_NORMAL = sys.float_info.min  # the least float above 0 that is not subnormal
MISSING: Any = REQUIRED  # the value shown in an error about a missing key


def _fmt(x: float) -> str:
    """A bound as a person writes it: 2147483647, 0.05, 1e+06."""
    if float(x).is_integer() and abs(x) < 1e12:
        return str(int(x))
    return f"{x:g}"


@dataclass(frozen=True)
class Field:
    """One key of a user table.

    `kind` is float, int, bool, str, list or dict. Numbers are range-checked in
    the file's own units (so the message repeats what the user wrote), then
    divided by `si_divisor`. `parse` replaces the built-in check for structured
    values: it gets (source, dotted key, raw value) and returns the converted
    value or raises InputError itself.
    """

    key: str  # TOML key, unit suffix included
    kind: type
    name: str = ""  # attribute it fills; default: the key itself
    unit: str = ""  # unit shown in messages ("km/h", "s", "m")
    lo: float | None = None  # lowest allowed value, in the file's unit
    hi: float | None = None  # highest allowed value, in the file's unit
    lo_open: bool = False  # lo itself not allowed
    hi_open: bool = False  # hi itself not allowed
    # smallest meaningful magnitude of a value other than 0, in the file's unit (None: the
    # smallest normal float; below it a number is subnormal, which SUMO cannot parse)
    least: float | None = None
    choices: tuple[str, ...] = ()  # allowed strings
    pattern: str = ""  # regular expression a string must match in full
    default: Any = REQUIRED  # REQUIRED, None (optional, absent -> None) or a value (SI)
    si_divisor: float = 1.0  # SI value = file value / si_divisor
    parse: Callable[[str, str, Any], Any] | None = None
    describe: str = ""  # what is allowed, for custom `parse` fields
    doc: str = ""  # what the key means (the key reference's "meaning" column)
    default_doc: str = ""  # how the reference shows a default that is not a plain value
    override: str = ""  # short name a batch study may vary it by (cosim.scenario.OVERRIDES)
    # SI value -> file value for structured keys (lists of tables, sub-tables, paths)
    export: Callable[[Any], Any] | None = None

    @property
    def attr(self) -> str:
        return self.name or self.key

    def allowed(self) -> str:
        """What is allowed, in words (the last part of an error message)."""
        if self.describe:
            text = self.describe
        elif self.kind is bool:
            text = "true or false"
        elif self.kind is str:
            if self.choices:
                text = "one of " + ", ".join(repr(c) for c in self.choices)
            elif self.pattern:
                text = f"a string matching {self.pattern}"
            else:
                text = "a string"
        elif self.kind in (int, float):
            noun = "an integer" if self.kind is int else "a finite number"
            lo, lo_open, zero = self.lo, self.lo_open, ""
            if self.least is not None and lo is not None and 0 <= lo <= self.least:
                # the least meaningful value is the bound; 0 itself stays if it was allowed
                zero = "" if lo_open or lo > 0 else "0 or "
                lo, lo_open = self.least, False
            if lo is not None and self.hi is not None:
                left = "(" if lo_open else "["
                right = ")" if self.hi_open else "]"
                text = f"{zero}{noun} in {left}{_fmt(lo)}, {_fmt(self.hi)}{right}"
            elif lo is not None:
                text = f"{zero}{noun} {'>' if lo_open else '>='} {_fmt(lo)}"
            elif self.hi is not None:
                text = f"{noun} {'<' if self.hi_open else '<='} {_fmt(self.hi)}"
            else:
                text = noun
            if self.unit:
                text += f" {self.unit}"
            if self.least is not None and not zero and lo != self.least:
                text += f" (0 or at least {_fmt(self.least)} in magnitude)"
        else:
            text = f"a {self.kind.__name__}"
        if self.default is REQUIRED:
            text = "required: " + text
        return text

    def convert(self, source: str, key: str, value: Any) -> Any:
        """Check one given value and return it in SI; raise InputError if it is not allowed."""
        if self.parse is not None:
            return self.parse(source, key, value)
        bad = InputError(source, key, value, self.allowed())
        if self.kind is bool:
            if not isinstance(value, bool):
                raise bad
            return value
        if self.kind is str:
            if not isinstance(value, str):
                raise bad
            if self.choices and value not in self.choices:
                close = difflib.get_close_matches(value, self.choices, n=1, cutoff=0.5)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise InputError(source, key, value, self.allowed() + hint)
            if self.pattern and not re.fullmatch(self.pattern, value):
                raise bad
            return value
        if self.kind in (int, float):
            # bool is an int in Python; `true` is never a number here.
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise bad
            if self.kind is int and not isinstance(value, int):
                raise bad
            if isinstance(value, float) and not math.isfinite(value):
                raise bad
            # Compare before any float() so huge TOML integers cannot overflow.
            if self.lo is not None and (value < self.lo or (self.lo_open and value == self.lo)):
                raise bad
            if self.hi is not None and (value > self.hi or (self.hi_open and value == self.hi)):
                raise bad
            least = SMALLEST_NORMAL if self.least is None else self.least
            if value != 0 and abs(value) < least:
                raise InputError(source, key, value, self.allowed() + (
                    "" if self.least is not None else
                    f" (0 or at least {SMALLEST_NORMAL:.3g} in magnitude: a subnormal number "
                    "is no quantity, and SUMO cannot read it)"))
            if self.kind is int:
                return value
            return float(value) / self.si_divisor if self.si_divisor != 1.0 else float(value)
        if not isinstance(value, self.kind):
            raise bad
        return value

    def to_file_units(self, value: Any) -> Any:
        """The inverse of `convert` (SI -> the file's unit and shape)."""
        if self.export is not None:
            return self.export(value)
        if self.kind is float and value is not None and self.si_divisor != 1.0:
            # Round away the ulp that m/s -> km/h adds (25.0 m/s -> 90.0, not 90.00000000000001).
            return round(value * self.si_divisor, 9)
        return value


def declare(spec: Field, default: Any = dataclasses.MISSING) -> Any:
    """A dataclass field that carries `spec` (its file key, unit, range, default, doc), so a
    key is declared once, beside the attribute it fills; `declared_fields` reads them back."""
    return dataclasses.field(default=default, metadata={"key": spec})


@functools.cache
def declared_fields(cls: type) -> tuple[Field, ...]:
    """The `Field`s of a dataclass's `declare`d attributes, in order, named for them."""
    return tuple(
        dataclasses.replace(f.metadata["key"], name=f.name)
        for f in dataclasses.fields(cls)
        if "key" in f.metadata
    )


def not_a_file(path: Any) -> str | None:
    """Why `path` cannot be read as a file, in words ("not found", "a folder", "a character
    device", a dangling link ...), or None when it is a regular file (symlinks followed)."""
    import os
    import stat
    from pathlib import Path

    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        return "a dangling symbolic link" if p.is_symlink() else "not found"
    except (OSError, ValueError) as exc:
        return getattr(exc, "strerror", None) or str(exc)
    if stat.S_ISREG(mode):
        return None if os.access(p, os.R_OK) else "not readable (permission denied)"
    return file_kind(mode)


def not_utf8(path: Any) -> str | None:
    """Why SUMO cannot open `path` although it exists: its name holds bytes that are not
    UTF-8 (SUMO takes file names as UTF-8); None when it can."""
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        shown = str(path).encode("utf-8", "surrogateescape").decode("utf-8", "replace")
        return (f"its name {shown!r} holds bytes that are not UTF-8, and SUMO reads UTF-8 "
                "names only: rename the file or its folder")
    return None


def network_file(path: Any, max_bytes: int) -> Any:
    """The os.stat_result of a SUMO network file about to be read. InputError when it is
    not a readable regular file (saying what it is: `not_a_file`) or is over `max_bytes`."""
    from pathlib import Path

    why = not_a_file(path)
    if why is not None:
        raise InputError(str(path), "network", f"{path} ({why})",
                         "an existing SUMO .net.xml file")
    why = not_utf8(path)
    if why is not None:
        raise InputError(str(path), "name", str(path), f"a file name SUMO can open ({why})")
    st = Path(path).stat()
    if st.st_size > max_bytes:
        raise InputError(str(path), "size", f"{st.st_size} bytes",
                         f"a network file of at most {max_bytes // 2**20} MiB")
    return st


MAX_NETWORK_BYTES = 64 * 2**20  # a motorway net is kB to a few MB: refuse bigger unread


def read_network_file(path: Any, reader: Any) -> Any:
    """What `reader(path, mtime_ns, size)` (a function cached on those three, returning its
    result or an InputError) makes of the SUMO network at `path`, after `network_file`'s
    checks with MAX_NETWORK_BYTES: a file is parsed once per process as it stands."""
    st = network_file(path, MAX_NETWORK_BYTES)
    found = reader(str(path), st.st_mtime_ns, st.st_size)
    if isinstance(found, InputError):
        raise found
    return found


def file_kind(mode: int) -> str:
    """What a file of this st_mode is, in words ("a folder", "a character device", ...)."""
    import stat

    for test, what in ((stat.S_ISREG, "a file"), (stat.S_ISDIR, "a folder"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISFIFO, "a named pipe"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return what
    return "not a regular file"


def suggest(key: str, known: Sequence[str]) -> str:
    """' (did you mean 'x'?)' for a close known key, else ''."""
    close = difflib.get_close_matches(key, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def check_table(source: str, table_name: str, raw: Any) -> Mapping[str, Any]:
    """`raw` must be a table (a dict with string keys)."""
    if not isinstance(raw, Mapping) or not all(isinstance(k, str) for k in raw):
        raise InputError(source, table_name or "(document)", raw, "a table of key = value pairs")
    return raw


def validate_table(
    source: str, table_name: str, raw: Any, specs: Sequence[Field]
) -> dict[str, Any]:
    """Validate one table: returns {field.attr: SI value} for every field (defaults filled in).

    `table_name` prefixes keys in messages ("sv" -> "sv.speed_kmh", "" -> "speed_kmh").
    Raises InputError on an unknown key (with a suggestion), a missing required
    key, a wrong type or a value out of range.
    """
    table = check_table(source, table_name, raw)
    prefix = f"{table_name}." if table_name else ""
    by_key = {f.key: f for f in specs}
    for key, value in table.items():
        if key not in by_key:
            raise InputError(
                source,
                prefix + key,
                value,
                f"unknown key{suggest(key, list(by_key))}; allowed: {', '.join(by_key)}",
            )
    out: dict[str, Any] = {}
    for f in specs:
        if f.key in table:
            out[f.attr] = f.convert(source, prefix + f.key, table[f.key])
        elif f.default is REQUIRED:
            raise InputError(source, prefix + f.key, MISSING, f.allowed())
        else:
            out[f.attr] = f.default
    return out


def check_known_tables(source: str, doc: Mapping[str, Any], known: Sequence[str]) -> None:
    """Reject top-level tables/keys that are not in `known`, with a suggestion."""
    for key, value in doc.items():
        if key not in known:
            raise InputError(
                source,
                key,
                value,
                f"unknown table{suggest(key, known)}; allowed: {', '.join(known)}",
            )


def parse_tables(source: str, key: str, value: Any, cls: type, many: int) -> Any:
    """A sub-table of `cls`'s declared keys as a `cls`, or (many > 0) a list of at most
    `many` of them as a tuple."""
    specs = declared_fields(cls)
    if not many:
        return cls(**validate_table(source, key, value, specs))
    if not isinstance(value, list) or len(value) > many:
        raise InputError(source, key, value, f"a list of at most {many} tables")
    return tuple(cls(**validate_table(source, f"{key}[{i}]", item, specs))
                 for i, item in enumerate(value))


def table_to_dict(specs: Sequence[Field] | type, obj: Any) -> dict[str, Any]:
    """One table in file units: `specs` (or a dataclass's declared keys) read from `obj`
    (attributes or a mapping); absent optional keys (None) are left out."""
    if isinstance(specs, type):
        specs = declared_fields(specs)
    out: dict[str, Any] = {}
    for f in specs:
        value = obj[f.attr] if isinstance(obj, Mapping) else getattr(obj, f.attr)
        if value is None:
            continue  # absent optional key (TOML has no null)
        out[f.key] = f.to_file_units(value)
    return out
