"""a femu model from a Nastran deck or an OpenSeesPy script (importing a script RUNS it)

`femu import FILE --out MODEL.json` reads a Nastran bulk-data deck (.bdf, .dat, .nas, .blk;
with or without executive and case control, read with pyNastran) or an OpenSeesPy script
(.py) and writes the model as a femu model file (docs/import.md). A deck has no units:
--units names the consistent system it is written in (the model file is SI, and records the
units, the mass convention and the source path in its "meta"). Nastran's mass is lumped
unless PARAM COUPMASS is set (--mass deck); --mass lumped|consistent overrides it.

Importing an OpenSeesPy script runs it, as `python SCRIPT` would, with the permissions of
this user: import only scripts you trust. The model is read from the OpenSees domain it built.

Examples:
  femu import frame.bdf --out frame.model.json
  femu import frame.dat --units mm-N-t --mass consistent --out frame.model.json
  femu import frame.py --out frame.model.json
"""

from __future__ import annotations

from fe_problem.units import UNITS

from pathlib import Path

#: File suffixes read as Nastran decks; .py is an OpenSeesPy script.
NASTRAN_SUFFIXES = (".bdf", ".dat", ".nas", ".blk", ".bulk")


def add_arguments(p) -> None:
    p.add_argument("file", metavar="FILE", help="a Nastran deck (.bdf .dat .nas .blk) or an OpenSeesPy script (.py)")
    p.add_argument("--out", required=True, metavar="MODEL.json", help="the model file to write")
    p.add_argument("--from", dest="kind", choices=("nastran", "opensees"), default=None,
                   help="the file's kind (default: from its suffix)")
    p.add_argument("--units", default="SI", choices=tuple(UNITS),
                   help="a deck's consistent unit system (SI: m kg N s; mm-N-t: mm tonne N s; in-lbf-s: inch "
                        "lbf-s^2/in lbf s); an OpenSees script's likewise")
    p.add_argument("--mass", default="deck", choices=("deck", "lumped", "consistent"),
                   help="(Nastran) the beams' mass: as the deck says (lumped unless PARAM COUPMASS), or forced; "
                        "an OpenSees script's elements say theirs (-cMass)")
    p.add_argument("--name", default=None, help="the model's name (default: the file's stem)")


def kind_of(path: Path, kind: str | None) -> str:
    """'nastran' or 'opensees' for `path` (its suffix), or `kind` when given."""
    if kind:
        return kind
    suffix = path.suffix.lower()
    if suffix in NASTRAN_SUFFIXES:
        return "nastran"
    if suffix == ".py":
        return "opensees"
    raise ValueError(f"{path}: suffix {suffix or '(none)'!r}: expected a Nastran deck "
                     f"({', '.join(NASTRAN_SUFFIXES)}) or an OpenSeesPy script (.py), or say --from")


def run(args) -> int:
    from fe_problem.model import save_model

    path = Path(args.file)
    kind = kind_of(path, args.kind)
    if kind == "nastran":
        from fe_problem.model.nastran import read_bdf
        model = read_bdf(path, units=args.units, mass=args.mass, name=args.name)
    else:
        if args.mass != "deck":
            raise ValueError(f"--mass {args.mass}: an OpenSees script's elements say their mass (-cMass or not); "
                             "--mass is for Nastran decks")
        from fe_problem.model.opensees import read_script
        model = read_script(path, units=args.units, name=args.name)
    out = save_model(model, args.out)
    rec = model.meta["import"]
    print(f"wrote {out}: {len(model.nodes)} nodes, {len(model.elements)} elements, {len(model.masses)} masses, "
          f"{len(model.springs)} springs, {'space' if model.layout.dimension == 3 else 'planar'} frame, "
          f"{rec['mass']} mass, from {kind} ({rec['units']})")
    return 0
