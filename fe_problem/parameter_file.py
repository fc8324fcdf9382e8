"""Parameter files (format ``femu.parameters/1``, docs/parameters-format.md): which properties of
a frame model `femu update` and `femu study --model` may change, within which bounds.

`load_parameters(path, model)` reads one into the library's `Parameter`s, checking every rule
against the model; a broken rule is a `ParameterFileError` naming the file, the parameter and
the problem. `parameters_to_dict` writes them back.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .jsonutil import check_keys, read_json_file
from .model import FrameModel
from .model.validate import is_number, shown
from .parameters import PARAMETER_KINDS, Parameter, model_value

#: The format tag of a parameter file.
PARAMETERS_FORMAT = "femu.parameters/1"
FILE_KEYS = ("format", "parameters")
PARAMETER_KEYS = ("name", "kind", "targets", "lower", "upper", "initial")
#: The most parameters a file may list (an updating problem has far fewer).
MAX_PARAMETERS = 10_000
#: Kinds whose lower bound must be > 0 (a zero modulus or density is no structure); the others >= 0.
POSITIVE_KINDS = ("modulus", "density")


class ParameterFileError(ValueError):
    """A parameter file that breaks its format or does not fit its model."""


def load_parameters(path: str | Path, model: FrameModel) -> tuple[Parameter, ...]:
    """The parameters of the file at `path` for `model` (ParameterFileError naming the file,
    the parameter and the problem when a rule is broken)."""
    path = Path(path)
    return parameters_from_dict(read_json_file(path, ParameterFileError), model, str(path))


def parameters_from_dict(d: Any, model: FrameModel, source: str = "<memory>") -> tuple[Parameter, ...]:
    """Validate the parsed JSON of a parameter file against `model`."""
    def err(msg: str) -> ParameterFileError:
        return ParameterFileError(f"{source}: {msg}")

    if not isinstance(d, dict):
        raise err("the file must hold a JSON object")
    check_keys(d, FILE_KEYS, source, ParameterFileError)
    for key in FILE_KEYS:
        if key not in d:
            raise err(f"missing field '{key}'")
    if d["format"] != PARAMETERS_FORMAT:
        raise err(f"field 'format' must be {PARAMETERS_FORMAT!r}, got {shown(d['format'])}")
    items = d["parameters"]
    if not isinstance(items, list) or not items:
        raise err("field 'parameters' must be a non-empty list")
    if len(items) > MAX_PARAMETERS:
        raise err(f"field 'parameters': {len(items)} parameters are more than the {MAX_PARAMETERS} a file may hold")
    out: list[Parameter] = []
    names: set[str] = set()
    held: dict[tuple, str] = {}  # (kind, target) -> the parameter that holds it
    for k, item in enumerate(items):
        where = f"parameters[{k}]"
        if not isinstance(item, dict):
            raise err(f"{where}: must be an object, got {shown(item)}")
        name = item.get("name")
        if isinstance(name, str) and name:
            where = f"parameter {name!r}"
        check_keys(item, PARAMETER_KEYS, f"{source}: {where}", ParameterFileError)
        for key in ("name", "kind", "targets", "lower", "upper"):
            if key not in item:
                raise err(f"{where}: missing field '{key}'")
        if not isinstance(name, str) or not name.strip():
            raise err(f"{where}: field 'name' must be a non-empty string, got {shown(name)}")
        if name in names:
            raise err(f"{where}: the name is given to two parameters")
        names.add(name)
        kind = item["kind"]
        if kind not in PARAMETER_KINDS:
            raise err(f"{where}: field 'kind' must be one of {list(PARAMETER_KINDS)}, got {shown(kind)}")
        targets = _targets(item["targets"], kind, model, err, where)
        for t in targets if kind != "release" else [tuple(targets)]:
            if (kind, t) in held:
                raise err(f"{where}: {_what(kind)} {shown(list(t) if kind == 'release' else t)} is already "
                          f"in parameter {held[(kind, t)]!r}")
            held[(kind, t)] = name
        lower, upper = item["lower"], item["upper"]
        for key, v in (("lower", lower), ("upper", upper)):
            if not is_number(v):
                raise err(f"{where}: field '{key}' must be a finite number, got {shown(v)}")
        if not lower < upper:
            raise err(f"{where}: field 'lower' ({lower:g}) must be less than 'upper' ({upper:g})")
        if kind in POSITIVE_KINDS and lower <= 0:
            raise err(f"{where}: field 'lower' must be > 0 for a {kind}, got {lower:g}")
        if lower < 0:
            raise err(f"{where}: field 'lower' must be >= 0 for a {kind}, got {lower:g}")
        if "initial" in item:
            initial = item["initial"]
            if not is_number(initial):
                raise err(f"{where}: field 'initial' must be a finite number, got {shown(initial)}")
            if not lower <= initial <= upper:
                raise err(f"{where}: field 'initial' ({initial:g}) is outside [lower, upper] = [{lower:g}, {upper:g}]")
        else:
            try:
                initial = model_value(model, kind, targets)
            except ValueError as exc:
                raise err(f"{where}: {exc}; give 'initial'") from None
            if not lower <= initial <= upper:
                raise err(f"{where}: the model's own value {initial:g} (the default 'initial') is outside "
                          f"[lower, upper] = [{lower:g}, {upper:g}]")
        out.append(Parameter(kind, tuple(targets), float(lower), float(upper), float(initial), name=name))
    return tuple(out)


def _what(kind: str) -> str:
    return {"modulus": "element", "density": "element", "mass": "node", "spring": "spring",
            "release": "element end"}[kind]


def _targets(targets: Any, kind: str, model: FrameModel, err, where: str) -> list[int]:
    """The checked ids of a parameter's `targets`."""
    if not isinstance(targets, list) or not targets:
        raise err(f"{where}: field 'targets' must be a non-empty list of ids, got {shown(targets)}")
    for j, t in enumerate(targets):
        if isinstance(t, bool) or not isinstance(t, int):
            raise err(f"{where}: field 'targets'[{j}] must be an integer id, got {shown(t)}")
    if len(set(targets)) != len(targets):
        raise err(f"{where}: field 'targets' lists an id twice")
    if kind == "release":
        if len(targets) != 2:
            raise err(f"{where}: field 'targets' of a release is [element id, node id], got {shown(targets)}")
        e, node = targets
        if e not in model.element_ids:
            raise err(f"{where}: model {model.name!r} has no element {e}")
        el = model.element(e)
        if node not in (el.node_i, el.node_j):
            raise err(f"{where}: element {e} does not end at node {node}")
        i, j = model.end_releases(el)
        if not (i if node == el.node_i else j):
            raise err(f"{where}: the end of element {e} at node {node} is not released in the model")
        return list(targets)
    known = {"modulus": model.element_ids, "density": model.element_ids, "mass": model.node_ids,
             "spring": tuple(s.id for s in model.springs)}[kind]
    known_set = set(known)
    for t in targets:
        if t not in known_set:
            raise err(f"{where}: model {model.name!r} has no {_what(kind)} {t}")
    return list(targets)


def parameters_to_dict(parameters) -> dict:
    """The JSON-ready dictionary of a parameter file."""
    return {"format": PARAMETERS_FORMAT,
            "parameters": [{"name": p.label, "kind": p.kind, "targets": list(p.targets), "lower": p.lower,
                            "upper": p.upper, "initial": p.initial} for p in parameters]}


__all__ = ["PARAMETERS_FORMAT", "ParameterFileError", "load_parameters", "parameters_from_dict",
           "parameters_to_dict"]
