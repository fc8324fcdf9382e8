"""Optimizer registry: the built-ins and third-party plugins.

A plugin is a class with a `name` and
``minimize(objective, bounds, budget, rng, **options)``: `objective` takes a batch (n, n_var)
and returns n values, `bounds` is (xl, xu), `rng` a numpy Generator. The harness enforces the
budget by raising from `objective`; the plugin's return value is ignored. An optional class
attribute `min_budget` says how many evaluations the method needs to start.

Third parties register under the entry-point group ``femu.optimizers`` (name -> class).
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points

ENTRY_POINT_GROUP = "femu.optimizers"

#: Built-in optimizers: name -> "module:Class", imported only when used.
BUILTINS = {
    "pymoo-ga": "adapters.pymoo_ga:PymooGA",
    "deap-ga": "adapters.deap_ga:DeapGA",
    "pyswarms-pso": "adapters.pyswarms_pso:PyswarmsPSO",
    "scipy-sa": "adapters.scipy_sa:ScipyDualAnnealing",
    "mlp-surrogate": "adapters.mlp_surrogate:MLPSurrogate",
    "random-search": "adapters.random_search:RandomSearch",
    "cma-es": "adapters.cma_es:CMAES",
    "sensitivity": "adapters.sensitivity:Sensitivity",
}


def _plugins() -> dict:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available() -> list[str]:
    """Names of every optimizer that can be run: built-ins, then plugins."""
    return list(BUILTINS) + sorted(set(_plugins()) - set(BUILTINS))


def get(name: str) -> type:
    """The optimizer class registered as `name`; ValueError naming the known ones."""
    if name in BUILTINS:
        module, cls = BUILTINS[name].split(":")
        return getattr(importlib.import_module(module), cls)
    plugins = _plugins()
    if name in plugins:
        return plugins[name].load()
    raise ValueError(f"unknown optimizer {name!r}; available: {', '.join(available())}")
