"""Parsing of a study's lists: seeds (``0-29``, ``0,3,7``) and names (``a,b``).

One seed syntax for every command: a list of seeds and ranges (``0-29``, ``0,3,7``,
``0-4,10``). `femu reproduce` also takes a bare count N, meaning the N seeds 0..N-1
(`parse_seed_count`); `femu study` does not (there ``5`` is the seed 5).
"""

from __future__ import annotations

import re


def parse_seeds(spec) -> list[int]:
    """Seeds from ``"0-29"``, ``"0,3,7"`` or a mix (``"0-4,10"``), or from a list of ints.

    ValueError for anything else: negative or non-integer seeds, a descending range, an empty
    spec, a seed given twice."""
    hint = "seeds are integers >= 0, e.g. 0-29 or 0,3,7"
    if isinstance(spec, str):
        items = [s.strip() for s in spec.split(",")]
        if not spec.strip() or any(not s for s in items):
            raise ValueError(f"--seeds {spec!r}: empty seed in the list ({hint})")
        seeds: list[int] = []
        for item in items:
            m = re.fullmatch(r"(\d+)(?:-(\d+))?", item, flags=re.ASCII)
            if m is None:
                raise ValueError(f"--seeds {spec!r}: {item!r} is not a seed or a range a-b ({hint})")
            a = int(m[1])
            b = int(m[2]) if m[2] is not None else a
            if b < a:
                raise ValueError(f"--seeds {spec!r}: range {item!r} runs backwards (write {b}-{a})")
            seeds.extend(range(a, b + 1))
    else:
        seeds = []
        for s in spec:
            if isinstance(s, bool) or not hasattr(s, "__index__") or s.__index__() < 0:
                raise ValueError(f"seeds: {s!r} is not a seed ({hint})")
            seeds.append(s.__index__())
        if not seeds:
            raise ValueError(f"seeds: no seed given ({hint})")
    dup = sorted({s for s in seeds if seeds.count(s) > 1})
    if dup:
        raise ValueError(f"--seeds {spec!r}: seed {dup[0]} is given twice")
    return seeds


def parse_names(spec, what: str) -> list[str]:
    """Names from ``"a,b"`` or a list; ValueError naming flag `what` for an empty or repeated name."""
    names = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else [str(s) for s in spec]
    if not names or any(not n for n in names):
        raise ValueError(f"--{what} {spec!r}: empty name in the list")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"--{what}: {dup[0]!r} is given twice")
    return names



def parse_seed_count(spec) -> list[int]:
    """Seeds for `femu reproduce`: a bare whole number N (an int or a string of digits) is a
    count, the N seeds 0..N-1 (N >= 1); anything else is a list as for `parse_seeds`."""
    text = str(spec).strip() if isinstance(spec, (str, int)) and not isinstance(spec, bool) else None
    if text is not None and text.isdigit():
        n = int(text)
        if n < 1:
            raise ValueError(f"--seeds {spec!r}: a count of seeds must be >= 1 (N means the seeds 0..N-1; "
                             f"a single seed s is written s-s)")
        return list(range(n))
    return parse_seeds(spec)
