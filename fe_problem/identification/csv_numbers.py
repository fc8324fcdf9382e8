"""The number table of a CSV file's body, checked: the one place the readers of FRF CSV
(frf_io.py) and time-series CSV (timeseries_io.py) turn their lines into floats."""

from __future__ import annotations

import numpy as np


def number_table(rows: list[tuple[int, str]], header: list[str], where: str, error, note: str = "") -> np.ndarray:
    """The (len(rows), len(header)) floats of `rows` ((1-based line number, text) each), parsed in
    one pass. `error` (an exception class) is raised with one line naming `where`, the line, the
    column and the problem: a line with another count of fields than the header (`note` says what
    the header's columns are), a field that is not a number, a NaN or infinite one ('nan', 'inf',
    or beyond a float: 1e400)."""
    width = len(header)
    counts = np.fromiter((text.count(",") for _, text in rows), int, len(rows))
    wrong = np.flatnonzero(counts != width - 1)
    if wrong.size:
        r = int(wrong[0])
        raise error(f"{where}: line {rows[r][0]}: {counts[r] + 1} fields, but the header has {width} columns{note}")
    try:
        table = np.array(",".join(text for _, text in rows).split(","), dtype=float).reshape(len(rows), width)
    except ValueError:
        for number, text in rows:  # the slow path only to name the bad field
            for c, v in enumerate(text.split(",")):
                try:
                    float(v)
                except ValueError:
                    raise error(f"{where}: line {number}: column {c + 1} ({header[c]}): {v.strip()!r} "
                                "is not a number") from None
        raise
    bad = np.argwhere(~np.isfinite(table))
    if bad.size:
        r, c = (int(i) for i in bad[0])
        number, text = rows[r]
        raise error(f"{where}: line {number}: column {c + 1} ({header[c]}): {text.split(',')[c].strip()!r} is not "
                    "a finite number (NaN or infinite): every field needs one")
    return table
