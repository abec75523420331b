"""Atomic output: a file is either absent, or complete.

Every result file is written to a temporary file in the same directory, flushed
and fsync'ed, then moved over the final name with `os.replace` (atomic on
POSIX and Windows within one file system). An interrupted run or study leaves
at most a hidden `.NAME.tmp-*` file behind, never a truncated CSV under its
final name. Output directories are created only when asked (after the input
has been validated), and `new_run_dir` picks names parallel runs cannot share.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

if TYPE_CHECKING:  # pandas is imported lazily: only CSV writers need it
    import pandas as pd

TEMP_MARK = ".tmp-"  # part of every temporary file's name


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
    final = Path(path)
    final.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{final.stem}{TEMP_MARK}", suffix=final.suffix, dir=final.parent
    )
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        # Whatever wrote the file may not have synced it: do it here, before the rename.
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, final)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    _fsync_dir(final.parent)


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """`open(path, mode)` whose result appears under `path` only when the block completes."""
    if not mode.startswith("w") or "+" in mode:
        raise ValueError(f"atomic_open writes whole files: mode {mode!r} must be 'w' or 'wb'")
    with atomic_path(path) as tmp, open(tmp, mode, **kwargs) as fh:
        yield fh  # closed before atomic_path syncs and renames it


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` atomically; returns `path`."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


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


def check_output_dir(path: str | Path, source: str = "command line", key: str = "--out") -> Path:
    """Check, without creating anything, that `path` can be used as an output folder.

    Call it with the other input checks, before a run: a folder that cannot be
    created must be an InputError up front, not a traceback after an hour of
    simulation. It must be a directory we can write into, or not exist yet
    below a writable directory.
    """
    from cosim.errors import InputError

    out = Path(path)
    try:
        if out.exists():
            if not out.is_dir():
                raise InputError(source, key, str(out), "a folder (this is a file)")
            if not os.access(out, os.W_OK | os.X_OK):
                raise InputError(source, key, str(out), "a folder we may write into")
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


def stale_temp_files(directory: str | Path) -> list[Path]:
    """Temporary files left by interrupted writers in `directory` (safe to delete)."""
    d = Path(directory)
    if not d.is_dir():
        return []
    return sorted(p for p in d.iterdir() if p.name.startswith(".") and TEMP_MARK in p.name)
