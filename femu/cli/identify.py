"""identify modes (frequencies, damping, shapes) from frequency responses or ambient records

`femu identify FRF_FILE [FRF_FILE...] [--model M] [--band LO HI] [--modes N] [--out DIR] [--json]`
reads FRFs (UFF dataset 58, `.npz` or CSV: docs/identify.md), finds the stable physical poles
over LSCF model orders (sdypy-EMA), fits the residues and writes DIR/modal-data.json
(femu.modal-data/1, ready for `femu diagnose`), DIR/identification.json and DIR/report.md with
the stabilisation chart, the FRF fit and the shapes. --json prints the modal-data document as
the only thing on stdout. Progress (a TTY, or --progress) and warnings go to stderr; bad input
is one line on stderr and exit code 2.

`femu identify FILE [FILE...] --oma [--model M] [--method ssi-cov|plscf|fdd] [--fs HZ] [--band LO HI]
[--order MAX] [--units g] --out DIR` reads response time series of an ambient test (CSV or .npz,
several setups merged through their reference channels: docs/identify-ambient.md) and
identifies the modes by operational modal analysis (pyOMA2): DIR/modal-data.json with each
mode's frequency_std_hz and shape_std, identification.json and report.md.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path

from ._args import directory, positive_int


def _stderr(msg: str, end: str = "\n") -> None:
    print(f"femu identify: {msg}", file=sys.stderr, end=end, flush=True)


def add_arguments(p) -> None:
    p.add_argument("frf_files", nargs="+", metavar="FILE",
                   help="UFF 58 (.uff/.unv), .npz or .csv FRF files; with --oma, .csv or .npz time series")
    p.add_argument("--model", default=None,
                   help="model name or file (default: the one the FRF file names; with --oma, none: the channels keep "
                        "their labels)")
    p.add_argument("--band", nargs=2, type=float, metavar=("LO", "HI"), default=None,
                   help="frequency band in Hz (default: every line)")
    p.add_argument("--modes", type=positive_int, default=None, help="keep the lowest N modes (default: all found)")
    p.add_argument("--out", default="femu-identify", type=directory, help="output directory (default femu-identify)")
    p.add_argument("--max-order", type=positive_int, default=40, help="highest LSCF order, pole pairs (default 40)")
    p.add_argument("--max-damping", type=float, default=0.10, help="largest physical damping ratio (default 0.10)")
    p.add_argument("--progress", action="store_true", help="show progress on stderr even when it is not a terminal")
    p.add_argument("--json", action="store_true", help="print the modal-data document on stdout")
    oma = p.add_argument_group("ambient vibration (--oma)")
    oma.add_argument("--oma", action="store_true", help="the files are response time series of an ambient test")
    oma.add_argument("--method", choices=("ssi-cov", "plscf", "fdd"), default="ssi-cov",
                     help="operational modal analysis method (pyOMA2)")
    oma.add_argument("--fs", type=float, default=None, help="sampling frequency in Hz (for CSV files without time_s)")
    oma.add_argument("--order", type=positive_int, default=None,
                     help="highest model order (SSI: state dimension, default 40; pLSCF: default 30)")
    oma.add_argument("--units", choices=("m/s^2", "g"), default="m/s^2", help="units of the accelerations")


def _model_reference(name: str, out: Path) -> str:
    """The model as the data file should name it: a shipped name, or a path relative to `out`."""
    if not Path(name).is_file():  # a shipped model's name
        return name
    return os.path.relpath(Path(name).resolve(), out.resolve())


def run(args) -> int:
    """Entry point of `femu identify`."""
    from dataclasses import replace

    from fe_problem import identify, read_frf, save_modal_data
    from fe_problem.jsonutil import jsonable
    from fe_problem.safe_files import write_text
    from femu.reports.identify import summary_record, write_report
    from femu.reports.render import make_out_dir

    if args.oma:
        from ._oma import run_oma
        return run_oma(args)
    from adapters.extras import require

    require("modal identification (femu identify)", "sdypy")  # before the work: the extra to install
    if not (math.isfinite(args.max_damping) and 0 < args.max_damping < 1):
        raise ValueError(f"--max-damping must lie in (0, 1), got {args.max_damping}")
    out = Path(args.out)  # refused at parsing if it is not a directory (_args.directory); made by make_out_dir
    show = args.progress or sys.stderr.isatty()
    frfs = read_frf(*args.frf_files)
    if show:
        _stderr(f"{frfs.n_channels} channels, {frfs.frequency_hz.size} lines, reference {frfs.reference}; "
                f"LSCF orders 1-{args.max_order} ...")

    tty = sys.stderr.isatty()

    def progress(done, total):
        if tty:  # one line rewritten in place
            _stderr(f"stabilisation: order {done}/{total}", end="\r" if done < total else "\n")
        elif done % 10 == 0 or done == total:  # a log: a line every 10 orders
            _stderr(f"stabilisation: order {done}/{total}")

    t0 = time.perf_counter()
    ident = identify(frfs, model=args.model, band_hz=args.band, n_modes=args.modes, max_order=args.max_order,
                     max_damping=args.max_damping, progress=progress if show else None)
    wall_s = time.perf_counter() - t0
    data = replace(ident.data, model=_model_reference(ident.data.model, out),
                   meta={**ident.data.meta, "wall_s": round(wall_s, 3)})
    make_out_dir(out)
    record = {**summary_record(ident), "wall_s": wall_s}
    written = [save_modal_data(data, out / "modal-data.json")]
    write_text(out / "identification.json", json.dumps(jsonable(record), indent=1) + "\n")
    written += [out / "identification.json", write_report(ident, out)]
    for w in ident.warnings:
        _stderr(f"warning: {w}")
    if args.json:
        json.dump(json.loads((out / "modal-data.json").read_text()), sys.stdout, indent=1)
        sys.stdout.write("\n")
        for p in written:
            _stderr(f"wrote {p}")
        return 0
    print(summary_text(record))
    for p in written:
        print(f"wrote {p}")
    return 0


def summary_text(record: dict) -> str:
    """The terminal summary: one line per mode with its spread over the stable orders."""
    lines = [f"Identified {len(record['modes'])} modes from {', '.join(record['frf_files'])} "
             f"(model {record['model']}, reference {record['reference'][0]} {record['reference'][1]}, "
             f"band {record['band_hz'][0]:g}-{record['band_hz'][1]:g} Hz) in {record['wall_s']:.2f} s",
             "  mode  frequency Hz   std Hz  damping %    MPC  stable orders"]
    for m in record["modes"]:
        lines.append(f"  {m['mode']:4d}  {m['frequency_hz']:12.3f}  {m['frequency_std_hz']:7.3f}  "
                     f"{100 * m['damping_ratio']:9.3f}  {m['mpc']:.3f}  {m['n_orders']:6d}")
    lines += [f"  warning: {w}" for w in record["warnings"]]
    return "\n".join(lines)
