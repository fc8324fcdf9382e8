"""list the optimizers: capabilities, option defaults, where each comes from and its version

Each built-in and each installed plugin (entry-point group femu.optimizers), with its
declared capabilities (anytime: the first k evaluations do not depend on the budget, so its
fixed-budget values below the budget are honest; uses_gradients; batch: whole populations per
call; supports_x0), the distribution that provides it and its version, the library it wraps,
and minimize's keyword options with their defaults (None: derived by the adapter, see its
docstring). `femu study --option NAME.KEY=VALUE` sets an option.
"""

from __future__ import annotations

import sys

from ._args import print_json


def add_arguments(p) -> None:
    """The arguments of `femu optimizers`."""
    p.add_argument("names", nargs="?", default=None,
                   help="optimizer names or package.module:Class paths, comma-separated (default: every available one)")
    p.add_argument("--json", action="store_true", help="a JSON list, one object per optimizer")


def _entries(names) -> tuple[list[dict], dict[str, str]]:
    """The described optimizers, and {name: the line saying which extra to install} for the
    built-ins whose library is not installed."""
    from adapters.capabilities import describe
    from adapters.registry import available, get, missing_extra
    from femu.studies.seeds import parse_names

    chosen = available() if names is None else parse_names(names, "names")
    out, unavailable = [], {}
    for name in chosen:
        why = missing_extra(name)
        if why and names is None:
            unavailable[name] = why
            continue
        try:
            out.append(describe(name, get(name)))
        except ValueError as exc:  # a broken plugin: named on stderr, the others still listed
            if names is not None:
                raise
            print(f"femu optimizers: warning: {exc}", file=sys.stderr)
    return out, unavailable


def _yes(v: bool) -> str:
    return "yes" if v else "no"


def run(args) -> int:
    """`femu optimizers [NAMES] [--json]`: the table or the JSON list."""
    entries, unavailable = _entries(args.names)
    if args.json:  # the list stays what can run; what cannot says why on stderr
        for why in unavailable.values():
            print(f"femu optimizers: unavailable: {why}", file=sys.stderr)
        print_json(entries)
        return 0
    head = ["name", "anytime", "gradients", "batch", "x0", "from", "wraps"]
    rows = [[e["name"], _yes(e["anytime"]), _yes(e["uses_gradients"]), _yes(e["batch"]), _yes(e["supports_x0"]),
             f"{e['distribution'] or '(not installed)'} {e['version'] or ''}".strip(),
             f"{e['library']} {e['library_version'] or ''}".strip() if e["library"] else "-"] for e in entries]
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(head)]
    line = lambda cells: "  ".join(c.ljust(w) for c, w in zip(cells, widths)).rstrip()  # noqa: E731
    print(line(head))
    print(line(["-" * w for w in widths]))
    for r in rows:
        print(line(r))
    print()
    for e in entries:
        opts = ", ".join(f"{k}={v!r}" for k, v in e["options"].items()) or "(none)"
        print(f"{e['name']}: {opts}")
    if unavailable:
        print("\nunavailable here (their extra is not installed):")
        for name, why in unavailable.items():
            print(f"{name}: {why}")
    return 0
