"""write a femu model as a Nastran deck or an OpenSeesPy script

`femu export MODEL --to bdf|opensees --out FILE` writes the model (a shipped name or a model
file) as a Nastran deck (SOL 103, large-field double precision) or as an OpenSeesPy script
that builds it and prints its frequencies (docs/import.md). `--like SOURCE.bdf` (bdf only)
writes SOURCE.bdf again with the model's changed MAT1, PBAR/PBEAM, CONM2 and CELAS values and
every other card as it was: an updated model of an imported deck, back to its deck.

Examples:
  femu export hframe --to bdf --out hframe.bdf
  femu export frame3d --to opensees --out frame3d.py
  femu export updated.model.json --to bdf --like frame.bdf --out frame-updated.bdf
"""

from __future__ import annotations

from fe_problem.units import UNITS


def add_arguments(p) -> None:
    p.add_argument("model", metavar="MODEL", help="a shipped model name (hframe, frame3d) or a model file")
    p.add_argument("--to", required=True, choices=("bdf", "opensees"), help="the file's kind")
    p.add_argument("--out", required=True, metavar="FILE", help="the file to write")
    p.add_argument("--like", default=None, metavar="SOURCE.bdf",
                   help="(bdf) write this deck again with the model's values; 'source': the deck the imported "
                        "model records")
    p.add_argument("--units", default=None, choices=tuple(UNITS),
                   help="the deck's or script's unit system (default: the units the model was imported in, else SI)")


def run(args) -> int:
    from fe_problem.model import load_model

    model = load_model(args.model)
    units = args.units or model.meta.get("import", {}).get("units", "SI")
    if args.to == "bdf":
        from fe_problem.model import nastran
        if args.like:
            source = nastran.source_of(model) if args.like == "source" else args.like
            if source is None:
                raise ValueError(f"{args.model}: --like source: the model records no Nastran deck it came from")
            out = nastran.write_like(model, source, args.out)
            print(f"wrote {out}: {source} with {model.name}'s values")
            return 0
        out = nastran.write_bdf(model, args.out, units=units)
    else:
        if args.like:
            raise ValueError("--like is for --to bdf")
        from fe_problem.model import opensees
        out = opensees.write_script(model, args.out, units=units)
    print(f"wrote {out}: {len(model.nodes)} nodes, {len(model.elements)} elements ({units})")
    return 0
