"""Files that ship with the project: models (``NAME.model.json``) and measured modal data
(``NAME.modal.json``), found by name."""

from __future__ import annotations

from pathlib import Path

SHIPPED_DIR = Path(__file__).resolve().parent


def shipped_names(suffix: str) -> tuple[str, ...]:
    """Names of the shipped files ending in `suffix` (e.g. ``".model.json"``), sorted."""
    return tuple(sorted(p.name[: -len(suffix)] for p in SHIPPED_DIR.glob(f"*{suffix}")))


def resolve(name_or_path, suffix: str, kind: str) -> Path:
    """The file of a shipped name (no extension) or a path; FileNotFoundError naming the
    shipped ones of this `kind` (``"model"``, ``"data"``) if neither exists."""
    path = Path(name_or_path)
    if not path.suffix and str(name_or_path) in shipped_names(suffix):
        path = SHIPPED_DIR / f"{name_or_path}{suffix}"
    if not path.exists():
        plural = "dataset" if kind == "data" else kind
        raise FileNotFoundError(
            f"no {kind} file {str(name_or_path)!r} and no shipped {plural} of that name "
            f"(shipped: {', '.join(shipped_names(suffix))})")
    return path
