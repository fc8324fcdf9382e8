"""Writing output files without following links: the one way every file the project writes
is opened (reports, records, data and model files, figures).

A symbolic link already standing in an output directory (`report.md -> ~/.bashrc`) would make
a write land outside that directory. Files are therefore opened with O_NOFOLLOW and a link at
the name is refused with a message naming it; the directory the user chose may itself be a
link (that is the user's choice), but no link inside it is followed.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path


class OutputPathError(ValueError):
    """An output path that is not written: a symbolic link, or a directory, at the file's name."""


def open_for_writing(path: str | Path, binary: bool = False, newline: str | None = None):
    """`path` opened for writing (created or truncated), never through a symbolic link."""
    path = Path(path)
    flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags, 0o666)
    except OSError as exc:
        if exc.errno == errno.ELOOP or path.is_symlink():
            raise OutputPathError(f"{path}: is a symbolic link (to {os.readlink(path)!r}); femu does not write "
                                  "through links: remove it or choose another output directory") from None
        if exc.errno == errno.EISDIR:
            raise OutputPathError(f"{path}: is a directory; femu writes a file of that name there") from None
        raise
    return os.fdopen(fd, "wb" if binary else "w", **({} if binary else {"encoding": "utf-8", "newline": newline}))


def write_text(path: str | Path, text: str) -> Path:
    """Write `text` (UTF-8) to `path` without following a link there; returns the path."""
    with open_for_writing(path) as fh:
        fh.write(text)
    return Path(path)


def refuse_link(path: str | Path) -> Path:
    """`path`, or OutputPathError if a symbolic link stands there: for writers that open the
    file themselves (pyuff, numpy)."""
    path = Path(path)
    if path.is_symlink():
        raise OutputPathError(f"{path}: is a symbolic link (to {os.readlink(path)!r}); femu does not write through "
                              "links: remove it or choose another output directory")
    return path
