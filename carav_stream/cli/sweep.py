"""`carav sweep`: Monte Carlo PF(eta) and PM(eta) curves of the CARAV detector, thresholds, JSON and a plot.

    carav sweep [--preset NAME | --scene FILE] [--nr N --ns N --iq] [--receivers N] --attack KIND[,KIND]
                --rarms LIST --trials N --eta START:STOP:STEP [--seed S] [--json FILE] [--plot FILE.png]

The scene comes from the radar signal chain (`carav_stream.radar`, every attacker model); `--model paper` uses the
paper's own model instead (attacks none, random, smart). `--method auto` draws per-chirp energies from their exact
laws where the scene allows it and simulates every sample otherwise. `--receivers N` (default the scene's own count,
else 1): C on each chirp's RMS over N receivers; the paper model takes any N (independent noise per receiver, one
attacker's signal on all of them at broadside, every sample simulated: carav_stream/montecarlo/array_source.py), the
radar model the scene's own.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from carav_stream.console import jsonout
from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import count, even_count, float_list, number, output_file
from carav_stream.console.progress import ProgressBar
from carav_stream.detect.detector import PAPER_ETA
from carav_stream.firmware.design import scene_law, threshold_warning
from carav_stream.montecarlo.curves import plot_curves, reference_eta
from carav_stream.montecarlo.detectors import DETECTORS
from carav_stream.montecarlo.engine import eta_grid, sweep
from carav_stream.montecarlo.sources import source_from_spec
from carav_stream.montecarlo.study import execute, results
from carav_stream.montecarlo.study_file import Group, Study
from carav_stream.radar.synth import FIDELITIES

__all__ = ["configure", "run", "build_source", "design_hint", "sweep_spec"]


def configure(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--preset", default=None, help="scene preset: table1, awr1642, awr1642_literal (default table1)")
    where.add_argument("--scene", default=None, help="scene TOML file")
    parser.add_argument("--model", choices=("radar", "paper"), default="radar",
                        help="radar: the full signal chain (default); paper: the paper's R = n + rho x + a model")
    parser.add_argument("--nr", type=even_count(2), default=None, help="override the number of chirps per cycle N_r")
    parser.add_argument("--ns", type=count(1), default=None, help="override the samples per chirp N_s")
    parser.add_argument("--iq", action="store_true", help="complex I/Q samples instead of I only")
    parser.add_argument("--snr-db", type=float, default=None,
                        help="per-sample echo SNR of the first target, dB (default: the scene's own, e.g. +2.2 dB "
                             "for table1 from MATLAB's radar equation; the paper's runs: 0)")
    parser.add_argument("--ideal-adc", action="store_true", help="no quantisation (adc_bits = 0)")
    parser.add_argument("--receivers", type=count(1), default=None, metavar="N",
                        help="receivers whose samples C combines per chirp (default the scene's own, else 1; the "
                             "paper model takes any N, the radar model the scene's own)")
    parser.add_argument("--fidelity", choices=FIDELITIES, default="auto",
                        help="signal model of the radar chain: beat (fast, analytic beat tones), waveform (the "
                             "IF filter and each slot's start as the receiver sees them, sample by sample), auto "
                             "(beat unless an attacker transmits its own waveform)")
    parser.add_argument("--attack", default="random", help="attacker kind(s), comma separated (default random)")
    parser.add_argument("--attack-param", action="append", default=[], metavar="KIND.KEY=VALUE",
                        help="extra attacker parameter, e.g. ghost.range_m=25 (repeatable)")
    parser.add_argument("--activation", choices=("seeded", "lfsr", "secure"), default="seeded",
                        help="activation source of the victim (lfsr to show the lfsr_predictor attack)")
    parser.add_argument("--rarms", type=float_list(low=0.0), default="0.5,1,2,3,5",
                        help="comma-separated RARMS values (sigma_a / sigma_n)")
    parser.add_argument("--trials", type=count(1), default=1000, help="cycles per curve (default 1000, as the paper)")
    parser.add_argument("--detector", default="carav",
                        help="detector(s) to score, comma separated: carav (C(eta), default), spectral, integrated, "
                             "coherent, spill "
                             "(opt-in; their statistic is in units of its PF = 1e-6 threshold, so eta = 1 is that "
                             "design; full samples, radar model)")
    parser.add_argument("--eta", default="0.5:2.5:0.01", help="threshold grid START:STOP:STEP")
    parser.add_argument("--seed", type=count(0), default=None, help="seed for reproducible runs")
    parser.add_argument("--method", choices=("auto", "energy", "samples"), default="auto",
                        help="per-chirp energy draws (exact laws) or full sample simulation")
    parser.add_argument("--cfar-pf", type=number(0.0, strict=True), default=0.01,
                        help="false-alarm target of the CFAR design")
    parser.add_argument("--design-rarms", type=number(0.0), default=3.0,
                        help="top-level thresholds are designed against the worst PM over RARMS >= this")
    parser.add_argument("--workers", type=count(1), default=2, help="threads for independent batches")
    parser.add_argument("--scheduler", metavar="tcp://HOST:PORT", default=None,
                        help="draw on an existing Dask cluster, as carav study does (the same numbers)")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the result as JSON")
    parser.add_argument("--plot", type=output_file, default=None, metavar="FILE.png",
                        help="draw PF/PM against eta (matplotlib)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _parse_value(text: str):
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return {"true": True, "false": False}.get(text.lower(), text)


def build_source(args: argparse.Namespace):
    """The cycle source named by the arguments (radar chain, or the paper model)."""
    return source_from_spec(sweep_spec(args))


def sweep_spec(args: argparse.Namespace) -> dict:
    """The plain description of the source the arguments name (what a study's [[scenes]] entry says)."""
    params: dict = {}
    for item in args.attack_param:
        key, _, value = item.partition("=")
        kind, _, name = key.partition(".")
        if not (kind and name and value):
            raise CommandError(f"--attack-param expects KIND.KEY=VALUE, got {item!r}")
        params.setdefault(kind, {})[name] = _parse_value(value)
    if args.model == "paper" and args.scene:
        raise CommandError("--model paper takes --preset table1|awr1642, not --scene")
    if args.model == "paper" and args.fidelity != "auto":
        raise CommandError("--fidelity is the radar chain's signal model; --model paper has none")
    return {"model": args.model, "preset": args.preset, "scene": args.scene, "nr": args.nr, "ns": args.ns,
            "iq": args.iq, "snr_db": args.snr_db, "ideal_adc": args.ideal_adc, "activation": args.activation,
            "fidelity": args.fidelity, "attack_params": params, "receivers": args.receivers}


def design_hint(args: argparse.Namespace) -> str:
    """The `carav design` command for the scene the sweep's options describe (the paper model: its noise-only ADC
    and its 0 dB echo unless --snr-db says otherwise)."""
    paper = args.model == "paper"
    snr_db = args.snr_db if args.snr_db is not None or not paper else 0.0
    hint = "carav design " + (f"--scene {args.scene}" if args.scene else f"--preset {args.preset or 'table1'}")
    hint += "".join(f" --{k} {v:g}" for k, v in (("nr", args.nr), ("ns", args.ns), ("snr-db", snr_db),
                                                  ("receivers", args.receivers)) if v is not None)
    return hint + (" --iq" if args.iq else "") + (" --ideal-adc" if args.ideal_adc or paper else "")


def _ci(ci) -> str:
    """A 95 % confidence interval, rounded: [0.0012, 0.0101]."""
    return "" if ci is None else f"[{ci[0]:.4g}, {ci[1]:.4g}]"


def _print_table(result: dict, stream=None) -> None:
    stream = stream or sys.stdout
    eta = np.asarray(result["eta"])
    detector = result.get("detector", "carav")
    ref = reference_eta(detector)
    i15 = int(np.argmin(np.abs(eta - ref)))
    scene = result["scene"]
    snr_db = scene.get("snr_db", scene.get("echo_snr_db"))
    snr = "" if snr_db is None else f", echo SNR {snr_db:+.1f} dB per sample"
    if snr_db is not None and abs(snr_db) >= 0.05:
        snr += " (the paper's runs set 0 dB: --snr-db 0)"
    what = ("detector C(eta)" if detector == "carav"
            else f"detector {detector} (threshold in units of its PF = 1e-6 value)")
    fidelity = {"auto": "beat fidelity, waveform for an attacker that transmits its own"}.get(
        scene.get("fidelity"), f"{scene.get('fidelity')} fidelity")
    model = scene["model"] + (f", {fidelity}" if scene.get("fidelity") else "")
    if scene.get("n_rx", 1) > 1:
        model += f", {scene['n_rx']} receivers"
    print(f"scene {scene['name']} ({model}){snr}, {what}, {result['trials']} cycles per curve, "
          f"PF from {result['pf_method']}", file=stream)
    at = f"@{ref:g}"
    print(f"{'attack':<18}{'RARMS':>7}{'method':>9}{'PF' + at:>9}{'PM' + at:>9}  {'PM 95% CI' + at:<19}"
          "minimax eta (band)", file=stream)
    for c in result["curves"]:
        mm = c["thresholds"]["minimax"]
        lo, hi = c["pm_ci"][i15]
        print(f"{c['attack']:<18}{c['rarms']:>7g}{c['method']:>9}{c['pf'][i15]:>9.4f}{c['pm'][i15]:>9.4f}  "
              f"[{lo:.4f}, {hi:.4f}]   {mm['eta']:.3f} ({mm['eta_range'][0]:.2f}-{mm['eta_range'][1]:.2f}) "
              f"max={mm['value']:.4f}", file=stream)
    t = result["thresholds"]
    for name in ("minimax", "cfar", "min_sum"):
        d = t[name]
        if d.get("eta") is None:
            print(f"{name:>8}: {d.get('note')}", file=stream)
            continue
        print(f"{name:>8}: eta={d['eta']:.3f} PF={d['pf']:.4g} {_ci(d.get('pf_ci'))} "
              f"PM={d['pm']:.4g} {_ci(d.get('pm_ci'))}", file=stream)
    if "closed_form" in result:
        cf = result["closed_form"]
        print(f"closed form (Gaussian): PF(1.5) = {cf['pf_at_eta_1_5']:.3e}; CFAR eta for PF = 1e-6: "
              f"{cf['cfar_eta_pf_1e-6']:.4f}", file=stream)


def _on_dask(args, source, attacks, rarms, eta, detectors) -> list[dict]:
    """The sweep's draws on a Dask cluster, through carav study's tasks: one group per detector."""
    import tempfile
    from pathlib import Path

    if not args.scheduler.startswith(("tcp://", "tls://")):
        raise CommandError(f"--scheduler: expected tcp://HOST:PORT or tls://HOST:PORT, got {args.scheduler!r}")
    if args.seed is None:
        raise CommandError("--scheduler: needs --seed (every task draws from seeds spawned from it)")
    spec = sweep_spec(args)
    study = Study(Path("carav-sweep"), "carav sweep on Dask", args.seed, args.trials, eta, args.eta, None, 2_000_000,
                  args.method, args.cfar_pf, args.design_rarms,
                  [Group(source.name, d, spec) for d in detectors], [(a, float(r)) for a in attacks for r in rarms])
    try:
        with tempfile.TemporaryDirectory(prefix="carav-sweep-") as folder:
            bar = ProgressBar(f"study {study.path.stem}") if ProgressBar.wanted(args.quiet) else None
            draws = execute(study, Path(folder), scheduler=args.scheduler, progress=bar)
        return [g["result"] for g in results(study, draws)[0]]
    except ValueError as exc:              # a detector the source or method cannot serve
        raise CommandError(f"--detector: {exc}", Exit.USAGE) from None


def run(args: argparse.Namespace) -> int:
    try:
        eta = eta_grid(args.eta)
    except ValueError as exc:
        raise CommandError(f"--eta: {str(exc).removeprefix('eta: ')}") from None
    rarms = args.rarms
    attacks = [a.strip() for a in args.attack.split(",") if a.strip()]

    detectors = list(dict.fromkeys(d.strip() for d in args.detector.split(",") if d.strip()))
    unknown = [d for d in detectors if d not in DETECTORS]
    if unknown or not detectors:
        raise CommandError(f"--detector: unknown {', '.join(map(repr, unknown)) or 'empty list'}; expected "
                           f"{', '.join(DETECTORS)}", Exit.USAGE)
    try:
        source = build_source(args)
        for a in attacks:
            if hasattr(source, "make_attacker"):
                source.make_attacker(a, rarms[0])
            elif a not in source.attacks:
                raise ValueError(f"attack: {a!r} is not available in the paper model; expected one of "
                                 f"{', '.join(source.attacks)} (use --model radar for the others)")
    except (ValueError, TypeError) as exc:     # the scene or an attacker's parameters
        raise CommandError(str(exc), Exit.INVALID) from None

    hint = design_hint(args)
    warning = threshold_warning(scene_law(source.scene, getattr(source, "n_rx", 1)), PAPER_ETA, source.sigma_n,
                                who="the paper's", design_hint=hint)
    if warning:
        print(f"carav sweep: warning: {warning}", file=sys.stderr)
    t0 = time.perf_counter()
    results = []
    if args.scheduler is not None:
        results = _on_dask(args, source, attacks, rarms, eta, detectors)
    for detector in detectors:
        if args.scheduler is not None:
            _print_table(results[detectors.index(detector)])
            continue
        progress = ProgressBar(f"sweep {source.name} {detector}") if ProgressBar.wanted(args.quiet) else None
        try:
            results.append(sweep(source, attacks=attacks, rarms=rarms, n_trials=args.trials, eta=eta,
                                 seed=args.seed, method=args.method, target_pf=args.cfar_pf,
                                 design_rarms=args.design_rarms, workers=args.workers, progress=progress,
                                 detector=detector))
        except ValueError as exc:          # a detector the source or method cannot serve
            raise CommandError(f"--detector {detector}: {exc}", Exit.USAGE) from None
        _print_table(results[-1])
    result = results[0]
    if len(results) > 1:      # one JSON: every detector's curves, each detector's designed thresholds
        result["curves"] = [c for r in results for c in r["curves"]]
        result["detectors"] = detectors
        result["thresholds_by_detector"] = {r["detector"]: r["thresholds"] for r in results}
    result["elapsed_s"] = time.perf_counter() - t0
    result["command"] = " ".join(sys.argv)
    if args.json:
        jsonout.write(args.json, result, indent=1)
    if args.plot:
        plot_curves(result, args.plot)
        print(f"plot: {args.plot} (PF and PM against eta on a log axis, the ROC beneath)")
    return 0
