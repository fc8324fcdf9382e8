"""`femu identify --oma`: the ambient-vibration path of the identify command (docs/identify-ambient.md). Reads time series, identifies through fe_problem.identification.ambient,
writes modal-data.json (with each mode's frequency_std_hz and shape_std), identification.json
and report.md."""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path


def _stderr(msg: str) -> None:
    print(f"femu identify: {msg}", file=sys.stderr, flush=True)


def modal_data_document(data, modes) -> dict:
    """The modal-data JSON (femu.modal-data/1) of `data` with each mode's `frequency_std_hz` and
    `shape_std` (shared/formats/modal-data.md) where the identification states them."""
    from fe_problem.modal_data.json_format import modal_data_to_dict

    doc = modal_data_to_dict(data)
    for entry, m in zip(doc["modes"], modes):
        if m["frequency_std_hz"] is not None and m["frequency_std_hz"] > 0:
            entry["frequency_std_hz"] = float(m["frequency_std_hz"])
        if m["shape_std"] is not None:
            entry["shape_std"] = [float(v) for v in m["shape_std"]]
    return doc


def run_oma(args) -> int:
    """Entry point of `femu identify --oma`."""
    from dataclasses import replace

    from fe_problem.identification.ambient import identify_ambient
    from fe_problem.identification.timeseries_io import read_timeseries
    from fe_problem.jsonutil import dumps, jsonable
    from fe_problem.safe_files import write_text
    from femu.reports.oma import summary_record, summary_text, write_report
    from femu.reports.render import make_out_dir

    from .identify import _model_reference

    if args.fs is not None and not (math.isfinite(args.fs) and args.fs > 0):
        raise ValueError(f"--fs must be a positive number of Hz, got {args.fs}")
    out = Path(args.out)
    rec = read_timeseries(*args.frf_files, fs=args.fs, units=args.units)
    if args.progress or sys.stderr.isatty():
        _stderr(f"{len(rec.setups)} setup(s), {len(rec.channels)} channels at {rec.fs:g} Hz; {args.method} ...")
    t0 = time.perf_counter()
    ident = identify_ambient(rec, model=args.model, method=args.method, band_hz=args.band, order=args.order)
    wall_s = time.perf_counter() - t0
    modes = list(ident.modes)
    data = ident.data
    if args.modes is not None and args.modes < data.n_modes:
        data, modes = data.subset(range(args.modes)), modes[:args.modes]
        ident = replace(ident, data=data, modes=tuple(modes))
    model = None if data.model is None else _model_reference(data.model, out)  # none: the channels' labels
    data = replace(data, model=model, meta={**data.meta, "wall_s": round(wall_s, 3)})
    make_out_dir(out)
    record = {**summary_record(ident), "wall_s": wall_s}
    doc = modal_data_document(data, modes)
    written = [write_text(out / "modal-data.json", dumps(doc) + "\n"),
               write_text(out / "identification.json", json.dumps(jsonable(record), indent=1) + "\n"),
               write_report(ident, record, out)]
    for w in ident.warnings:
        _stderr(f"warning: {w}")
    if args.json:
        sys.stdout.write(dumps(doc) + "\n")
        for p in written:
            _stderr(f"wrote {p}")
        return 0
    print(summary_text(record))
    for p in written:
        print(f"wrote {p}")
    return 0
