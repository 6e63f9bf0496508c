"""`carav export INPUT --mat OUT.mat`: a recording or a summary as a MATLAB file (v5: MATLAB and Octave load it).

    carav export rec1 --mat rec1.mat [--cycles A:B] [--no-activation]   a SigMF recording (carav record)
    carav export summary.json --mat summary.mat                          a summary written with --json

The variables, and how keys and values become MATLAB's: docs/RECORDINGS.md ("In MATLAB"). A recording's
activation log, when it lies beside the recording, goes into the file too, and the file is then its owner's alone
(mode 0600); --no-activation leaves it out. A recording larger than a MATLAB v5 variable holds (2 GiB) is refused
before anything is written, with the number of cycles that fit.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from carav_stream.capture.activation_log import log_path
from carav_stream.capture.recording_export import recording_variables, rows_between
from carav_stream.capture.sigmf_io import RecordingError, base_of, open_recording
from carav_stream.console import matout
from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import output_file, span
from carav_stream.console.progress import ProgressBar

__all__ = ["configure", "run"]

SIGMF = (".sigmf-meta", ".sigmf-data")
CLASS_WORDS = {"int16": "int16", "float32": "single", "complex64": "complex single"}


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", type=Path, help="a recording (its folder, base name or .sigmf-meta) or a JSON summary "
                   "(carav run --json)")
    p.add_argument("--mat", type=output_file, required=True, metavar="OUT.mat", help="the MATLAB file to write")
    p.add_argument("--cycles", type=span, metavar="A:B", help="a recording's cycles A to B-1 only (either end may "
                   "be left out)")
    p.add_argument("--no-activation", action="store_true", help="leave a recording's activation sequence out (a "
                   "file to share)")
    p.add_argument("--quiet", action="store_true", help="no progress (on stderr: a bar on a terminal, else a line "
                   "every 10 s with the time left)")


def _is_recording(path: Path) -> bool:
    base = path.with_suffix("") if path.suffix in SIGMF else path
    return path.is_dir() or path.suffix in SIGMF or any(Path(f"{base}{s}").exists() for s in SIGMF)


def run(args: argparse.Namespace) -> int:
    path = args.input
    if not path.exists() and not _is_recording(path):
        raise CommandError(f"{path}: no such file, folder or recording")
    if _is_recording(path):
        return _export_recording(args)
    for given, option in ((args.cycles, "--cycles"), (args.no_activation, "--no-activation")):
        if given:
            raise CommandError(f"{option}: only for a recording; {path} is a summary")
    matout.write(args.mat, {"summary": read_summary(path)})
    print(f"wrote {args.mat}: summary")
    return Exit.OK


def read_summary(path: Path) -> dict:
    """The JSON object of a summary file; CommandError (Exit.INVALID) naming the file otherwise."""
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise CommandError(f"{path}: neither a JSON summary nor a SigMF recording: {exc}", Exit.INVALID) from None
    if not isinstance(data, dict):
        raise CommandError(f"{path}: a summary is a JSON object (as --json writes it), this file holds a "
                           f"{type(data).__name__}", Exit.INVALID)
    return data


def _export_recording(args: argparse.Namespace) -> int:
    first, stop = args.cycles or (None, None)
    try:
        with_log = not args.no_activation and log_path(base_of(args.input)).exists()
        rec = open_recording(args.input, with_log=with_log)
        variables, adc = recording_variables(rec, rows_between(rec.cycles, first, stop))
    except RecordingError as exc:
        raise CommandError(str(exc), Exit.INVALID) from None
    if args.cycles and not adc.shape[0]:
        held = f"cycles {rec.cycles.min()} to {rec.cycles.max()}" if len(rec.cycles) else "no cycle"
        raise CommandError(f"--cycles {first if first is not None else ''}:{stop if stop is not None else ''}: "
                           f"{rec.base} holds {held}")
    bar = ProgressBar("export", unit="MiB") if ProgressBar.wanted(args.quiet) else None
    try:
        matout.write(args.mat, variables, {"adc": adc}, private=rec.rho is not None, progress=bar)
    except matout.VariableTooLarge as exc:
        fit = matout.MAX_VARIABLE_BYTES // exc.row_bytes
        raise CommandError(f"{rec.base}: its ADC frames ({adc.shape[0]} cycles) take {exc.nbytes / 2 ** 30:.2f} GiB, "
                           f"over the 2 GiB a MATLAB v5 variable holds; export at most {fit} cycles at a time with "
                           "--cycles A:B") from None
    shape = " x ".join(str(d) for d in adc.shape)          # cycles x [receivers x] chirps x samples
    also = ", activation (the file is mode 0600: it holds the activation sequence)" if rec.rho is not None else \
        ", no activation (" + ("--no-activation" if args.no_activation else f"no {log_path(rec.base).name}") + ")"
    print(f"wrote {args.mat}: adc {shape} {CLASS_WORDS[adc.dtype.name]}, cycle_index, "
          f"per_cycle, scene, meta, captures{also}")
    return Exit.OK
