"""Optimizer registry: the built-ins and third-party plugins.

A plugin is a class implementing `adapters.protocol.Optimizer`: a `name`,
``min_budget(n_var, **options)`` (or a plain int attribute ``min_budget``) and
``minimize(objective, bounds, budget, rng, **options)``. The harness (adapters.harness.run)
enforces the budget; adapters.budget holds the budget rules.

Third parties register under the entry-point group ``femu.optimizers`` (name -> class), e.g.
in their pyproject.toml::

    [project.entry-points."femu.optimizers"]
    my-method = "my_package.module:MyMethod"

A built-in name cannot be taken over by a plugin.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from importlib.metadata import entry_points

ENTRY_POINT_GROUP = "femu.optimizers"

#: Built-in optimizers: name -> "module:Class", imported only when used.
BUILTINS = {
    "pymoo-ga": "adapters.pymoo_ga:PymooGA",
    "deap-ga": "adapters.deap_ga:DeapGA",
    "deap-ga-stock": "adapters.deap_stock:DeapGAStock",
    "pyswarms-pso": "adapters.pyswarms_pso:PyswarmsPSO",
    "scipy-sa": "adapters.scipy_sa:ScipyDualAnnealing",
    "mlp-surrogate": "adapters.mlp_surrogate:MLPSurrogate",
    "random-search": "adapters.random_search:RandomSearch",
    "cma-es": "adapters.cma_es:CMAES",
    "sensitivity": "adapters.sensitivity:Sensitivity",
    "nevergrad-ngopt": "adapters.nevergrad_ngopt:NevergradNGOpt",
    "optuna-cmaes": "adapters.optuna_samplers:OptunaCmaEs",
    "optuna-tpe": "adapters.optuna_samplers:OptunaTPE",
}

#: The libraries of the built-ins that are not in the core install (adapters.extras names
#: their extra): name -> import names. The others need only the core's libraries.
BUILTIN_NEEDS = {
    "nevergrad-ngopt": ("nevergrad",),
    "optuna-cmaes": ("optuna", "cmaes"),
    "optuna-tpe": ("optuna",),
}


def missing_extra(name: str) -> str | None:
    """Why built-in `name` cannot run here (its extra is not installed: the line to install it),
    or None (a plugin, or a built-in whose libraries are here)."""
    from .extras import MissingExtra, require

    try:
        require(f"optimizer {name!r}", *BUILTIN_NEEDS.get(name, ()))
    except MissingExtra as exc:
        return str(exc)
    return None


#: (distribution, version) of each plugin class loaded from an entry point, by class
_FROM: dict = {}


def loaded_from(cls) -> tuple[str, str] | None:
    """(distribution name, version) of the package whose entry point `get` loaded `cls` from,
    or None (a built-in, a class named by its import path, or not loaded through an entry point)."""
    return _FROM.get(cls)


def _plugins() -> dict:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available() -> list[str]:
    """Names of every optimizer that can be run: built-ins, then plugins."""
    return list(BUILTINS) + sorted(set(_plugins()) - set(BUILTINS))


def get(name: str) -> type:
    """The optimizer class registered as `name`, or named by its import path
    ``package.module:Class``; ValueError naming the known ones."""
    if name in BUILTINS:
        why = missing_extra(name)
        if why:
            from .extras import MissingExtra

            raise MissingExtra(why)
        module, cls = BUILTINS[name].split(":")
        return getattr(importlib.import_module(module), cls)
    if _is_import_path(name):  # no entry point's name has a colon (it separates name and value)
        return _import_path(name)
    plugins = _plugins()
    if name in plugins:
        ep = plugins[name]
        try:
            cls = ep.load()
        except Exception as exc:  # a broken third-party package: say which one
            raise ValueError(f"optimizer {name!r}: entry point {ep.value!r} in group {ENTRY_POINT_GROUP!r} "
                             f"could not be loaded: {type(exc).__name__}: {exc}") from exc
        cls = _checked(cls, f"optimizer {name!r}: entry point {ep.value!r}")
        dist = getattr(ep, "dist", None)
        if dist is not None:
            _FROM[cls] = (dist.name, dist.version)
        return cls
    if ":" in name:
        return _import_path(name)
    raise ValueError(f"unknown optimizer {name!r}; available: {', '.join(available())}")


#: A Python module path: identifiers joined by dots.
_DOTTED = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")


def check_name(name) -> str:
    """`name` if it names an optimizer (a built-in, an installed plugin or an import path
    ``package.module:Class``), checked without importing a plugin's code; ValueError naming the
    known ones otherwise. Whether it loads is found out where it runs (adapters.sandbox)."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"unknown optimizer {name!r}; available: {', '.join(available())}")
    if name in BUILTINS or _is_import_path(name) or name in _plugins():  # the scan of entry points last
        return name
    if ":" in name:
        raise ValueError(f"optimizer {name!r}: not a registry name or an import path package.module:Class "
                         f"(available: {', '.join(available())})")
    raise ValueError(f"unknown optimizer {name!r}; available: {', '.join(available())}")


def _is_import_path(name: str) -> bool:
    """Whether `name` has the form ``package.module:Class``."""
    module, colon, attr = name.partition(":")
    return bool(colon) and _DOTTED.fullmatch(module) is not None and attr.isidentifier()


def _import_path(name: str) -> type:
    """An optimizer named by its import path ``package.module:Class`` (not registered: for
    trying out a class, e.g. in a test, in every worker process of a study); a module that is
    not installed is looked for in the current directory (`_import_here`)."""
    module, _, attr = name.partition(":")
    if not _is_import_path(name):
        raise ValueError(f"optimizer {name!r}: not a registry name or an import path package.module:Class "
                         f"(available: {', '.join(available())})")
    try:
        cls = getattr(_import_here(module), attr)
    except (ImportError, AttributeError, ValueError) as exc:  # ValueError: an empty module name
        raise ValueError(f"optimizer {name!r}: cannot import {attr!r} from module {module!r} "
                         f"({type(exc).__name__}: {exc})") from None
    except (Exception, SystemExit) as exc:  # the module's own top-level code failed or exited
        raise ValueError(f"optimizer {name!r}: importing module {module!r} ran its top-level code, which raised "
                         f"{type(exc).__name__}: {str(exc)[:200]}") from None
    return _checked(cls, f"optimizer {name!r}")


def _import_here(module: str):
    """`module` imported; if no installed package or path entry has it, looked for in the
    current directory too (a researcher's ``my_method.py`` beside the study, without
    ``PYTHONPATH=.``: the console script's sys.path does not hold the current directory). The
    directory is appended, so an installed module of the same name wins."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        top = module.split(".")[0]
        here = os.getcwd()
        if exc.name != top or here in sys.path or "" in sys.path:
            raise
        sys.path.append(here)
        try:
            return importlib.import_module(module)
        except ModuleNotFoundError as again:
            if again.name == top:  # not here either: leave sys.path as it was
                sys.path.remove(here)
            raise


def _checked(cls, what: str) -> type:
    """`cls` if it looks like an optimizer class, else a ValueError starting with `what`."""
    if not isinstance(cls, type) or not callable(getattr(cls, "minimize", None)):
        raise ValueError(f"{what} is not an optimizer class "
                         f"(it has no minimize(objective, bounds, budget, rng, **options) method)")
    return cls


def module_of(name: str) -> str | None:
    """The module that defines optimizer `name` (a registry name or ``module:Class``), without
    importing it; None for an unknown name. Lets a process pool preload it."""
    if name in BUILTINS:
        return BUILTINS[name].split(":")[0]
    if ":" in name:
        return name.split(":")[0]
    plugins = _plugins()
    return plugins[name].module if name in plugins else None
