"""What an optimizer can do, as data (Nevergrad's way): read from class attributes, never
guessed from a run.

Every optimizer class may declare

- ``anytime`` (bool): its first k evaluations do not depend on the budget (a run of budget B
  is the first B evaluations of any longer run with the same seed), so its best-so-far after
  k < B evaluations is what a run of budget k would have found; fixed-budget views and ECDFs
  below the budget are honest only for such an optimizer;
- ``uses_gradients`` (bool): it asks the objective for residuals and Jacobians
  (``objective.least_squares``), each charged `adapters.budget.jacobian_cost`;
- ``batch`` (bool): it evaluates whole populations per call (one batch of FE evaluations);
- ``supports_x0`` (bool): it can be given the problem's initial point (``x0=``).

An undeclared ``anytime``, ``uses_gradients`` or ``batch`` counts as False (a report then
makes no claim it cannot back); an undeclared ``supports_x0`` is read from ``minimize``'s
signature (an ``x0`` keyword or ``**kwargs``), as `adapters.harness.check_takes_x0` does.
`describe` adds each optimizer's keyword defaults, where it comes from and its version: what
`femu optimizers` lists and a run record keeps.
"""

from __future__ import annotations

import inspect
from importlib.metadata import PackageNotFoundError, version
from typing import Any

#: The capability flags, in the order they are listed.
CAPABILITIES = ("anytime", "uses_gradients", "batch", "supports_x0")


def _takes_x0(cls) -> bool:
    try:
        params = inspect.signature(cls.minimize).parameters
    except (TypeError, ValueError):
        return False
    return "x0" in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


def capabilities(cls) -> dict[str, bool]:
    """{flag: bool} for an optimizer class (or instance); ValueError if a declared flag is not
    a bool (a plugin's ``anytime = "yes"`` is an error, not a truth value)."""
    out = {}
    for flag in CAPABILITIES:
        value = getattr(cls, flag, None)
        if value is None:
            value = _takes_x0(cls) if flag == "supports_x0" else False
        if not isinstance(value, bool):
            what = getattr(cls, "__name__", type(cls).__name__)
            raise ValueError(f"optimizer class {what}: capability {flag!r} must be True or False, got {value!r}")
        out[flag] = value
    return out


def default_options(cls) -> dict[str, Any]:
    """The keyword options of ``minimize`` and their defaults (x0 excluded: the study sets it)."""
    try:
        params = inspect.signature(cls.minimize).parameters
    except (TypeError, ValueError):
        return {}
    skip = {"self", "objective", "bounds", "budget", "rng", "x0"}
    return {n: p.default for n, p in params.items()
            if n not in skip and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
            and p.default is not inspect.Parameter.empty}


def effective_options(cls, options: dict) -> dict[str, Any]:
    """The options a run used: ``minimize``'s keyword defaults overridden by `options` (an
    option the signature does not list, taken by ``**kwargs``, is kept as given). A default of
    None means the adapter derives the value (its docstring says how)."""
    return {**default_options(cls), **dict(options)}


def distribution_of(cls) -> tuple[str | None, str | None]:
    """(distribution name, version) of the installed package that provides `cls`: femu-bench
    for the built-ins, the entry point's distribution for a registered plugin (as
    `adapters.registry.get` loaded it), else the distribution named like the class's top-level
    module if one is installed; (None, None) otherwise (a file in the current directory, a
    test's class). Cheap: no scan of every installed distribution (that took seconds, inside a
    run's time limit)."""
    from .registry import loaded_from

    top = cls.__module__.split(".")[0]
    if top == "adapters":
        name = "femu-bench"
    elif loaded_from(cls) is not None:
        return loaded_from(cls)
    else:
        beside = _distribution_beside(top)
        if beside is not None:
            return beside
        name = top
    try:
        return name, version(name)
    except PackageNotFoundError:
        return None, None


def _distribution_beside(top: str) -> tuple[str, str] | None:
    """(name, version) of the distribution installed in the directory that holds module `top`
    (a site-packages, or a `pip install --target DIR`) whose files include that module: found
    whatever the distribution is called (`femu-my-method` providing `my_method`); only that one
    directory's *.dist-info are read. None if there is none (a file in the current directory)."""
    import sys
    from importlib.metadata import distributions
    from pathlib import Path

    module = sys.modules.get(top)
    file = getattr(module, "__file__", None)
    if not file:
        return None
    path = Path(file).resolve()
    where = path.parent.parent if path.name == "__init__.py" else path.parent
    try:
        for dist in distributions(path=[str(where)]):
            listed = (dist.read_text("top_level.txt") or "").split()
            files = dist.files or []
            if top in listed or any(f.parts and f.parts[0] in (top, f"{top}.py") for f in files):
                name = dist.metadata["Name"]
                return (name, dist.version) if name and dist.version else None
    except (OSError, ValueError):
        return None
    return None


def describe(name: str, cls) -> dict[str, Any]:
    """One optimizer as data: name, class path, distribution and version, capabilities, options
    (keyword defaults) and, when the class says it, the library it wraps (``library``)."""
    dist, ver = distribution_of(cls)
    lib = getattr(cls, "library", None)
    lib_version = None
    if lib:
        try:
            lib_version = version(lib)
        except PackageNotFoundError:
            lib_version = None
    doc = (inspect.getdoc(cls) or "").strip().splitlines()
    return {"name": name, "class": f"{cls.__module__}:{cls.__qualname__}", "distribution": dist, "version": ver,
            "library": lib, "library_version": lib_version, **capabilities(cls),
            "options": default_options(cls), "summary": doc[0] if doc else ""}


def run_description(cls, options: dict) -> dict[str, Any]:
    """The run-record fields that say what ran: distribution, distribution_version,
    effective_options and capabilities (adapters.harness.RunResult). Options that are not JSON
    values (a run started from Python with an array) are kept as their repr."""
    dist, ver = distribution_of(cls)
    effective = {k: _plain(v) for k, v in effective_options(cls, options).items()}
    return {"distribution": dist, "distribution_version": ver, "effective_options": effective,
            "capabilities": capabilities(cls)}


def _plain(value):
    """`value` as JSON gives it back (a tuple becomes a list), or its repr if JSON cannot hold it."""
    import json

    try:
        return json.loads(json.dumps(value, allow_nan=False))
    except (TypeError, ValueError):
        return repr(value)


def check_options(name: str, cls, options: dict) -> None:
    """ValueError naming the first option `cls`'s minimize does not take (unless it takes
    **kwargs), and the options it does take."""
    try:
        params = inspect.signature(cls.minimize).parameters
    except (TypeError, ValueError):
        return
    if any(p.kind is p.VAR_KEYWORD for p in params.values()):
        return
    skip = {"self", "objective", "bounds", "budget", "rng", "x0"}
    known = [n for n, p in params.items() if n not in skip and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    for key in options:
        if key not in known:
            raise ValueError(f"optimizer {name!r} has no option {key!r}; its options: "
                             f"{', '.join(known) or '(none)'} (`femu optimizers {name}` lists them with defaults)")
