"""The optional parts of an install (pyproject.toml's extras) and the one line a missing one gives.

`pip install femu-bench` is the core: `femu model`, `update`, `diagnose`, `reproduce` and studies
of the design's optimizers (pymoo, deap, pyswarms, scipy; cma-es comes with pymoo). Everything
else is an extra, named here once. It lives in `adapters` (it imports nothing but importlib) so
that the registry can use it inside an optimizer's sandboxed process, where fe_problem cannot be
imported; femu's commands use it too:

    optimizers  nevergrad-ngopt, optuna-cmaes, optuna-tpe; IOHprofiler export (femu report --ioh)
    cluster     femu study --scheduler (a Dask cluster)
    identify    femu identify (sdypy-EMA's pole finding and shapes)
    import      UFF files (pyuff: modal data, FRFs), Nastran decks and OpenSees scripts

A feature whose library is absent raises `MissingExtra` (a ValueError: the CLI prints it as one
line, exit 2) saying which extra to install.
"""

from __future__ import annotations

import importlib.util

#: import name -> the extra that installs it
EXTRA_OF = {
    "nevergrad": "optimizers",
    "optuna": "optimizers",
    "cmaes": "optimizers",
    "ioh": "optimizers",
    "dask": "cluster",
    "distributed": "cluster",
    "sdypy": "identify",
    "pyuff": "import",
}


class MissingExtra(ValueError):
    """A feature whose optional library is not installed: the message names the extra."""


def has(module: str) -> bool:
    """Whether `module` (a top-level import name) can be imported, without importing it."""
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def missing(*modules: str) -> list[str]:
    """The modules among `modules` this Python cannot import."""
    return [m for m in modules if not has(m)]


def install_hint(extra: str) -> str:
    return f"pip install 'femu-bench[{extra}]'"


def require(what: str, *modules: str) -> None:
    """MissingExtra ("WHAT needs the 'X' extra: pip install 'femu-bench[X]'") if one of `modules`
    cannot be imported; `what` names the feature (an optimizer, an option, a command)."""
    absent = missing(*modules)
    if absent:
        extra = EXTRA_OF.get(absent[0].split(".")[0], "all")
        raise MissingExtra(f"{what} needs the {extra!r} extra: {install_hint(extra)} "
                           f"({', '.join(absent)} {'is' if len(absent) == 1 else 'are'} not installed)")
