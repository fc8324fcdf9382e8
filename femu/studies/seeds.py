"""Parsing of a study's lists: seeds (``0-29``, ``0,3,7``) and names (``a,b``).

One seed syntax for every command: a list of seeds and ranges (``0-29``, ``0,3,7``,
``0-4,10``). `femu reproduce` also takes a bare count N, meaning the N seeds 0..N-1
(`parse_seed_count`); `femu study` does not (there ``5`` is the seed 5).
"""

from __future__ import annotations

import re
from collections import Counter

#: The most seeds one study may name (a study of more runs is a typo, not a plan).
MAX_SEEDS = 100_000
#: The largest seed (numpy's SeedSequence takes any int, but a run record's seed fits 32 bits).
MAX_SEED = 2**32 - 1
#: The longest seed list (characters) parsed at all.
MAX_SPEC_CHARS = 100_000


def _shown(spec) -> str:
    """`spec` for an error message, cut to a readable length."""
    text = repr(spec)
    return text if len(text) <= 60 else text[:57] + "...'"


def parse_seeds(spec) -> list[int]:
    """Seeds from ``"0-29"``, ``"0,3,7"`` or a mix (``"0-4,10"``), or from a list of ints.

    ValueError for anything else: negative or non-integer seeds, a seed above `MAX_SEED`, a
    descending range, an empty spec, a seed given twice, more than `MAX_SEEDS` seeds. Time and
    memory are linear in the length of the spec and the number of seeds (checked before any
    range is expanded)."""
    hint = "seeds are integers >= 0, e.g. 0-29 or 0,3,7"
    if isinstance(spec, str):
        if len(spec) > MAX_SPEC_CHARS:
            raise ValueError(f"--seeds: a list of {len(spec)} characters is longer than {MAX_SPEC_CHARS}")
        items = [s.strip() for s in spec.split(",")]
        if not spec.strip() or any(not s for s in items):
            raise ValueError(f"--seeds {_shown(spec)}: empty seed in the list ({hint})")
        ranges = []
        for item in items:
            m = re.fullmatch(r"(\d{1,12})(?:-(\d{1,12}))?", item, flags=re.ASCII)
            if m is None:
                raise ValueError(f"--seeds {_shown(spec)}: {_shown(item)} is not a seed or a range a-b "
                                 f"of seeds <= {MAX_SEED} ({hint})")
            a = int(m[1])
            b = int(m[2]) if m[2] is not None else a
            if b < a:
                raise ValueError(f"--seeds {_shown(spec)}: range {item!r} runs backwards (write {b}-{a})")
            ranges.append((a, b))
        _check_sizes(spec, ranges)
        seeds = [s for a, b in ranges for s in range(a, b + 1)]
    else:
        seeds = []
        for s in spec:
            if isinstance(s, bool) or not hasattr(s, "__index__") or s.__index__() < 0:
                raise ValueError(f"seeds: {s!r} is not a seed ({hint})")
            seeds.append(s.__index__())
        if not seeds:
            raise ValueError(f"seeds: no seed given ({hint})")
        _check_sizes(spec, [(s, s) for s in seeds])
    dup = sorted(s for s, n in Counter(seeds).items() if n > 1)
    if dup:
        raise ValueError(f"--seeds {_shown(spec)}: seed {dup[0]} is given twice")
    return seeds


def _check_sizes(spec, ranges: list[tuple[int, int]]) -> None:
    """ValueError if a seed is above MAX_SEED or the ranges name more than MAX_SEEDS seeds."""
    top = max(b for _, b in ranges)
    if top > MAX_SEED:
        raise ValueError(f"--seeds {_shown(spec)}: seed {top} is above the largest seed {MAX_SEED}")
    count = sum(b - a + 1 for a, b in ranges)
    if count > MAX_SEEDS:
        raise ValueError(f"--seeds {_shown(spec)}: {count} seeds is more than the {MAX_SEEDS} one study may run")


def parse_names(spec, what: str) -> list[str]:
    """Names from ``"a,b"`` or a list; ValueError naming flag `what` for an empty or repeated name."""
    names = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else [str(s) for s in spec]
    if not names or any(not n for n in names):
        raise ValueError(f"--{what} {spec!r}: empty name in the list")
    dup = sorted(n for n, k in Counter(names).items() if k > 1)
    if dup:
        raise ValueError(f"--{what}: {dup[0]!r} is given twice")
    return names


def parse_seed_count(spec) -> list[int]:
    """Seeds for `femu reproduce`: a bare whole number N (an int or a string of digits) is a
    count, the N seeds 0..N-1 (N >= 1); anything else is a list as for `parse_seeds`."""
    text = str(spec).strip() if isinstance(spec, (str, int)) and not isinstance(spec, bool) else None
    if text is not None and text.isdigit():
        if len(text) > 12 or int(text) > MAX_SEEDS:
            raise ValueError(f"--seeds {_shown(spec)}: more than the {MAX_SEEDS} seeds one study may run")
        n = int(text)
        if n < 1:
            raise ValueError(f"--seeds {spec!r}: a count of seeds must be >= 1 (N means the seeds 0..N-1; "
                             f"a single seed s is written s-s)")
        return list(range(n))
    return parse_seeds(spec)
