"""Atomic output: a file is either absent, or complete; a run's folder holds either its
complete new result or exactly what it held before.

Every result file is written to a temporary file in the same directory, flushed
and fsync'ed, then moved over the final name with `os.replace` (atomic on
POSIX and Windows within one file system). An interrupted run or study leaves
at most a hidden `.NAME.tmp-*` file behind, never a truncated CSV under its
final name. Output directories are created only when asked (after the input
has been validated), and `new_run_dir` picks names parallel runs cannot share.

A run's folder is built whole in a hidden temporary sibling (`staged_dir`) and swapped in
when complete; names that would escape their folder (`check_name`: "", ".", "..", "../x")
are refused, and so is replacing a folder that holds anything a run does not write.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

if TYPE_CHECKING:  # pandas is imported lazily: only CSV writers need it
    import pandas as pd

TEMP_MARK = ".tmp-"  # part of every temporary file's name
OLD_MARK = ".old-"  # part of the name of a replaced run folder, until it is deleted
# after TEMP_MARK / OLD_MARK in every name cosim makes: what it finds left over is removed
# only under such a name (with mkstemp's 8 random characters), never a user's own
# `.x.tmp-mine`
OWN_MARK = "cosim-"
_RANDOM = "[a-z0-9_]{8}"  # the random part tempfile puts in a name
# A name that becomes one folder under results/ (scenario, study, --name): no "", ".",
# "..", no separator; it starts with a letter, digit or underscore.
NAME_PATTERN = r"[A-Za-z0-9_][A-Za-z0-9_.\-]{0,79}"
# What a run writes into its folder (CSVs and figures); a folder holding anything else is
# not replaced by a run.
RUN_SUFFIXES = (".csv", ".png", ".svg", ".pdf")
# Folders `staged_dir` swapped in, in this process: a signal after the swap finds the new
# run complete, and the command says so (cosim.cli).
COMPLETED: list[Path] = []


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# mkstemp makes 0600 files; results get the mode an ordinary open() would give them.
FILE_MODE = 0o666 & ~_read_umask()


def _fsync_dir(directory: Path) -> None:
    """Make the rename itself durable (POSIX); harmless where directories cannot be opened."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to `path`; on normal exit it replaces `path` atomically.

    The temporary name keeps the suffix, so writers that infer the format from
    it (matplotlib's `savefig`) work: `with atomic_path("fig.png") as tmp:
    fig.savefig(tmp)`. On an exception the temporary file is removed and `path`
    is left as it was.
    """
    from cosim.errors import OutputError

    final = Path(path)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{final.stem}{TEMP_MARK}{OWN_MARK}", suffix=final.suffix, dir=final.parent
        )
        os.close(fd)
    except OSError as exc:
        raise OutputError(final, exc) from exc
    tmp = Path(tmp_name)
    try:
        yield tmp
        # Whatever wrote the file may not have synced it: do it here, before the rename.
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, final)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(exc, OSError):  # a full disk, a vanished folder: one line, not a trace
            raise OutputError(final, exc) from exc
        raise
    _fsync_dir(final.parent)


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """`open(path, mode)` whose result appears under `path` only when the block completes."""
    if not mode.startswith("w") or "+" in mode:
        raise ValueError(f"atomic_open writes whole files: mode {mode!r} must be 'w' or 'wb'")
    with atomic_path(path) as tmp, open(tmp, mode, **kwargs) as fh:
        yield fh  # closed before atomic_path syncs and renames it


def atomic_write_text(path: str | Path, text: str, encoding: str = "utf-8") -> Path:
    """Write `text` to `path` atomically; returns `path`."""
    with atomic_open(path, "w", encoding=encoding, newline="") as fh:
        fh.write(text)
    return Path(path)


def atomic_write_json(path: str | Path, obj: Any) -> Path:
    """Write `obj` as indented JSON (keys in order given) atomically; returns `path`."""
    return atomic_write_text(path, json.dumps(obj, indent=2) + "\n")


def atomic_write_csv(path: str | Path, frame: pd.DataFrame, **to_csv_kwargs: Any) -> Path:
    """Write a DataFrame as CSV atomically (index off unless asked); returns `path`."""
    to_csv_kwargs.setdefault("index", False)
    with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
        frame.to_csv(fh, **to_csv_kwargs)
    return Path(path)


def check_name(source: str, key: str, value: object) -> str:
    """`value` as a folder name (NAME_PATTERN), or InputError: "", ".", "..", "../x", "a/b"
    would write into the current folder, its parent or outside results/."""
    from cosim.errors import InputError

    if not isinstance(value, str) or not re.fullmatch(NAME_PATTERN, value):
        raise InputError(source, key, value,
                         f"a folder name matching {NAME_PATTERN} (not '', '.', '..' or a path)")
    return value


def check_output_dir(path: str | Path, source: str = "command line", key: str = "--out",
                     *, whole: bool = False) -> Path:
    """Check, without creating anything, that `path` can be used as an output folder.

    Call it with the other input checks, before a run: a folder that cannot be
    created must be an InputError up front, not a traceback after an hour of
    simulation. It must be a directory we can write into, or not exist yet
    below a writable directory; never "" or "." or ".." (the current folder or its
    parent). `whole`: the folder will be replaced whole (`staged_dir`), so an existing
    one may hold only what a run writes (RUN_SUFFIXES files), nothing else.
    """
    from cosim.errors import InputError

    out = Path(path)
    if str(path) in ("", ".", "..") or out.name in ("", ".", ".."):
        raise InputError(source, key, str(path),
                         "a folder path naming its folder (not '', '.', '..' or a root)")
    try:
        problem = _link_problem(out)
        if problem is not None:
            raise InputError(source, key, str(out), f"a usable folder path ({problem})")
        if out.exists() and not out.is_dir():
            raise InputError(source, key, str(out), f"a folder (this is {_kind(out)})")
        if whole and out.is_dir():
            foreign = [p.name for p in out.iterdir()
                       if not (p.is_file() and p.suffix in RUN_SUFFIXES)]
            if foreign:
                raise InputError(
                    source, key, str(out),
                    "a new folder, an empty one or a previous run's (a run replaces it whole; "
                    f"this one holds {sorted(foreign)[:3]}, which a run does not write)")
        if out.exists():
            if not os.access(out, os.W_OK | os.X_OK):
                raise InputError(source, key, str(out), "a folder we may write into")
            beside = out.resolve().parent
            if whole and not os.access(beside, os.W_OK | os.X_OK):
                raise InputError(source, key, str(out),
                                 f"a folder in a folder we may write into (a run is built "
                                 f"beside it and swapped in; {beside} is read-only)")
            return out
        parent = out.absolute().parent
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise InputError(source, key, str(out), f"a folder path ({parent} is a file)")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise InputError(
                source, key, str(out), f"a folder we may create ({parent} is read-only)"
            )
    except OSError as exc:
        raise InputError(source, key, str(out), f"a usable folder path ({exc.strerror})") from None
    return out


def _link_problem(path: Path) -> str | None:
    """A symbolic link on the way to `path` (itself included) that leads nowhere: dangling,
    or a loop (mkdir would fail on it after the run, not before)."""
    for p in (path, *path.absolute().parents):
        if not p.is_symlink():
            continue
        try:
            os.stat(p)
        except FileNotFoundError:
            return f"{p} is a dangling symbolic link to {os.readlink(p)}"
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                return f"{p} is a symbolic link loop"
            return f"{p}: {exc.strerror}"
    return None


def _kind(path: Path) -> str:
    """What a path that is not a folder is, in words."""
    from cosim.validation import file_kind

    return file_kind(path.stat().st_mode)


def make_output_dir(path: str | Path) -> Path:
    """Create an output directory (and its parents) and return it.

    Call it only after every input has been validated: a rejected input must
    leave no folder behind.
    """
    out = Path(path)
    out.mkdir(parents=True, exist_ok=True)
    return out


def new_run_dir(base: str | Path, name: str) -> Path:
    """Create and return a fresh directory `base/NAME-YYYYmmdd-HHMMSS[-k]`.

    `mkdir(exist_ok=False)` makes the choice atomic, so parallel runs of the same
    scenario never write into one another's folder.
    """
    root = make_output_dir(base)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for k in range(10_000):
        candidate = root / (f"{name}-{stamp}" if k == 0 else f"{name}-{stamp}-{k}")
        try:
            candidate.mkdir()
        except FileExistsError:
            continue
        return candidate
    raise FileExistsError(f"no free run directory for {name!r} under {root}")


def _stage_names(final: Path) -> tuple[str, str]:
    """The name prefixes of `final`'s staging folders: `.NAME.tmp-cosim-` (being built),
    `.NAME.old-cosim-` (the replaced folder, until it is deleted); the owner's process id
    and tempfile's random part follow."""
    return f".{final.name}{TEMP_MARK}{OWN_MARK}", f".{final.name}{OLD_MARK}{OWN_MARK}"


def _stale_owner(path: Path, prefix: str) -> int | None:
    """The process id in the name of a staging folder `staged_dir` made
    (`<prefix><pid>-<random>`), None for anything else: a name of another form, a file,
    a symbolic link. Only such folders are ever removed or put back."""
    found = re.fullmatch(re.escape(prefix) + rf"(\d+)-{_RANDOM}", path.name)
    if found is None or path.is_symlink() or not path.is_dir():
        return None
    return int(found.group(1))


def _owner_alive(pid: int) -> bool:
    """Whether the process that made a staging folder still runs: a run into the same
    folder must not delete another live run's stage."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: alive
        return True
    return True


def recover_stale(final: str | Path) -> None:
    """Clean what a killed `staged_dir` left beside `final`: half-built folders are deleted;
    a replaced folder whose swap was cut short is put back (or deleted once it is swapped).
    Only folders under the names `staged_dir` makes (`_stale_owner`) whose owner is gone:
    a user's own `.NAME.tmp-*` or `.NAME.old-*` is left alone."""
    final = Path(final)
    parent = final.parent
    if not parent.is_dir():
        return
    temp, old = _stage_names(final)
    for p in sorted(parent.iterdir()):
        for prefix in (temp, old):
            owner = _stale_owner(p, prefix)
            if owner is None or _owner_alive(owner):
                continue
            if prefix == temp or final.exists():
                shutil.rmtree(p, ignore_errors=True)
            else:
                os.replace(p, final)


@contextlib.contextmanager
def staged_dir(path: str | Path) -> Iterator[Path]:
    """Yield a hidden temporary sibling of `path` to build a folder in; on normal exit it
    replaces `path` (the old folder is renamed aside, the new one renamed in, the old one
    deleted). On any exception (Ctrl-C, SIGTERM through `Terminated`) the temporary folder
    is deleted and `path` keeps exactly what it held. A SIGKILL leaves the hidden sibling,
    which the next `staged_dir` of the same folder cleans (`recover_stale`; the names
    carry the owner's process id, so a concurrent run's stage is left alone). The swap and
    the old folder's removal hold SIGINT / SIGTERM / SIGHUP until done (`signals_deferred`):
    a signal then finds the new folder in place (`COMPLETED`) and no hidden copy. A write
    that fails (no space left) is an `OutputError` naming the file as the user knows it."""
    from cosim.errors import OutputError, check_signals, signals_deferred

    final = Path(path)
    if final.is_symlink():  # a link to a folder: build beside the folder, keep the link
        final = final.resolve()
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        recover_stale(final)
        temp, old = _stage_names(final)
        pid = f"{os.getpid()}-"  # the owner, for recover_stale
        tmp = Path(tempfile.mkdtemp(prefix=temp + pid, dir=final.parent))
    except OSError as exc:
        raise OutputError(final, exc) from exc
    aside: Path | None = None
    swapped = False
    try:
        os.chmod(tmp, 0o777 & ~_read_umask())
        yield tmp
        check_signals()  # a signal that came while the folder was built: it is not swapped in
        # The swap and the old folder's removal run whole: a Ctrl-C or SIGTERM now is
        # held until the new folder is in place and no hidden copy is left, then delivered
        # (the command reports the run complete: `completed`).
        with signals_deferred():
            if final.exists():
                aside = Path(tempfile.mkdtemp(prefix=old + pid, dir=final.parent))
                os.replace(final, aside)  # an empty directory is replaced by rename(2)
            os.replace(tmp, final)
            swapped = True
            COMPLETED.append(final)
            _fsync_dir(final.parent)
            if aside is not None:
                shutil.rmtree(aside, ignore_errors=True)
    except BaseException as exc:
        if swapped:
            raise  # a signal held through the swap: the new run is in place
        with signals_deferred():  # a second Ctrl-C must not leave half of the clean-up
            shutil.rmtree(tmp, ignore_errors=True)
            if aside is not None and not final.exists():
                os.replace(aside, final)  # failed between the two renames: put it back
        kept = f"{final} keeps what it held" if final.exists() else f"{final} was not made"
        if isinstance(exc, OutputError) and exc.where.startswith(str(tmp)):
            # name the file as the user knows it, not its hidden staging copy
            raise OutputError(str(final) + exc.where[len(str(tmp)):], exc.reason,
                              kept) from exc
        if isinstance(exc, OSError):
            raise OutputError(final, exc, kept) from exc
        raise


def stale_temp_files(directory: str | Path) -> list[Path]:
    """Temporary files left by interrupted writers in `directory` (safe to delete): files
    under the names `atomic_path` makes (`.STEM.tmp-cosim-<random><suffix>`), no link."""
    d = Path(directory)
    if not d.is_dir():
        return []
    own = re.compile(rf"\..*{re.escape(TEMP_MARK + OWN_MARK)}{_RANDOM}(\.\w+)?")
    return sorted(p for p in d.iterdir()
                  if own.fullmatch(p.name) and p.is_file() and not p.is_symlink())
