"""carav: run, validate and steer carav-stream graphs; sweep thresholds; reproduce the paper.

    carav run GRAPH [--cycles N] [--set node.param=value | param=value ...] [--json FILE] [--mat FILE]
    carav record GRAPH --out DIR [carav run options]   the run's ADC output as SigMF (+ private activation log)
    carav replay DIR [--graph FILE] [--json FILE]       a recording through detection and ranging again
    carav export DIR|SUMMARY.json --mat OUT.mat [--cycles A:B]   a recording or a summary as a MATLAB file
    carav validate GRAPH ...
    carav graph GRAPH [--set ...] [--out PICTURE.svg|.png|.pdf]   the graph as a picture (or as text, without --out)
    carav blocks [TYPE]
    carav attackers [--brief]        the attacker models: what each puts on the air, hears and takes (markdown)
    carav estimators                 the estimation methods: how each reads range and velocity (markdown)
    carav scenes [NAME | FILE ...]   what a scene implies (resolution, max range and velocity, SNR, warnings)
    carav scenes --from-ti-cfg FILE.cfg [--out SCENE.toml]   the scene of a TI mmWave CLI profile
    carav capture inspect FILE --scene S [--lanes N] [--encoding E] [--json OUT]   what a DCA1000 capture holds
    carav status | carav stop [RUN] | carav swap NODE BLOCK [--set key=value ...] [--graph RUN]
    carav keys DIR             CURVE keys for a graph's tcp edges between machines, and its [security] table
    carav sweep ...            PF/PM Monte Carlo and threshold design
    carav study STUDY.toml [--workers N | --scheduler tcp://HOST:PORT] [--out DIR] [--plot]   sweeps on Dask
    carav reproduce ...        the paper's figures into reproduction/ (--in-place: docs/REPRODUCTION.md)
    carav design --preset NAME | --scene FILE [--pf 1e-6]   every detector's threshold for that PF per cycle
    carav experiment secondary-antenna | matlab-table1 | interference | cfar | clutter | latency | near-echoes
                     | blind-zones | fidelities | tracks | receivers | angles ...
    carav new block NAME [--kind filter|source|sink] [--dir DIR]   a block, its test and a graph to start from

Every command is a module with configure(parser) and run(args) -> exit code; only the module of the command asked
for is imported, which keeps a command's start-up short (the studies import scipy, Dask and matplotlib). Errors
are one line naming the option, file or field; --debug (anywhere on the command line) shows the traceback of an
unexpected one. The benchmarks (`python3 dev.py bench NAME`, outside the installed package) use the same parser.
"""
from __future__ import annotations

import argparse
import gc
import importlib
import os
import sys

from carav_stream.console.errors import EXIT_CODES_HELP, CommandError, Exit
from carav_stream.core.allocator import keep_freed_memory

COMMANDS = {
    "run": ("carav_stream.cli.run", "run a graph and print its summary"),
    "record": ("carav_stream.cli.record", "run a graph and record its ADC output as SigMF, rho in a private log"),
    "replay": ("carav_stream.cli.replay", "a SigMF recording through detection, gate and ranging again"),
    "export": ("carav_stream.cli.export", "a recording or a summary as a MATLAB file (.mat, v5: MATLAB and Octave)"),
    "validate": ("carav_stream.cli.validate", "check graph files without starting anything"),
    "graph": ("carav_stream.cli.graph", "draw a graph file: boxes, ports and labelled arrows (or its text)"),
    "blocks": ("carav_stream.cli.blocks", "list block types with their ports and parameters"),
    "attackers": ("carav_stream.cli.attackers", "the attacker models as a markdown table: what each sends and takes"),
    "estimators": ("carav_stream.cli.estimators", "the estimation methods as a markdown table: how each reads range "
                   "and velocity"),
    "scenes": ("carav_stream.cli.scenes", "what the presets or scene files imply: rates, resolution, SNR, warnings"),
    "capture": ("carav_stream.cli.capture", "inspect a TI DCA1000 capture: cycles, noise, chirp spread, cells"),
    "status": ("carav_stream.cli.status", "running graphs with per-node counters and rates"),
    "stop": ("carav_stream.cli.stop", "stop a running graph in order (sources first, drain, sinks last)"),
    "swap": ("carav_stream.cli.swap", "replace a running node's block while frames keep flowing"),
    "keys": ("carav_stream.cli.keys", "CURVE keys for a graph's tcp edges, and the [security] table naming them"),
    "sweep": ("carav_stream.cli.sweep", "PF/PM Monte Carlo over eta and RARMS, with threshold design"),
    "reproduce": ("carav_stream.cli.reproduce", "the paper's figures and claims beside ours, as markdown"),
    "study": ("carav_stream.cli.study", "a declarative grid of sweeps on Dask distributed: CSV, JSON, figures"),
    "design": ("carav_stream.cli.design", "detector thresholds of a scene for a target false-alarm rate"),
    "new": ("carav_stream.cli.new", "a new block to start from, its test (with the test kit) and a graph wiring it"),
}
EXPERIMENTS = {name: (f"carav_stream.cli.experiment.{name.replace('-', '_')}", text) for name, text in {
    "secondary-antenna": "the paper's Figures 6 to 8",
    "matlab-table1": "MATLAB's FMCWExample result beside our estimators",
    "interference": "another car's FMCW radar: false alarms by detector",
    "cfar": "the radar's CFAR target detection against its design",
    "clutter": "several targets and clutter: false alarms, the target list",
    "latency": "spill test: PF over echo power, PM over repeater latency",
    "near-echoes": "a near car's echo against every detector, attack-free",
    "blind-zones": "what each detector misses of the weak attacks, per scene",
    "fidelities": "beat against waveform fidelity at the range edge, loud",
    "tracks": "the car's picture of the road under attack, by defence",
    "receivers": "weak attacks against C on 1, 2, 4 and 8 receivers",
    "angles": "the chain's azimuth of one target against its bound",
}.items()}   # each in cli/experiment/, its engine in carav_stream/experiments/
GROUPS = {"experiment": ("the paper's experiments", EXPERIMENTS)}


def _add(sub, name: str, module: str, help_text: str, wanted: bool) -> None:
    """A subcommand; its module is imported only when the command line asks for it."""
    p = sub.add_parser(name, help=help_text, description=help_text)
    if wanted:
        mod = importlib.import_module(module)
        mod.configure(p)
        p.set_defaults(func=mod.run)


class Parser(argparse.ArgumentParser):
    """argparse, with a bad command line reported in one line (and the usage only on --help)."""

    def error(self, message: str) -> None:
        self.exit(Exit.USAGE, f"{self.prog}: {message} (see {self.prog} --help)\n")


def build_parser(argv: list[str] = (), *, prog: str = "carav", description: str = __doc__,
                 commands: dict = COMMANDS, groups: dict = GROUPS) -> argparse.ArgumentParser:
    """The parser of `prog` with `commands` (name: (module, help)) and `groups` of such tables (`carav experiment X`);
    only the module of the command that argv names is imported."""
    words = [a for a in argv if not a.startswith("-")]
    ap = Parser(prog=prog, description=description, epilog=EXIT_CODES_HELP,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (module, text) in commands.items():
        _add(sub, name, module, text, words[:1] == [name])
    for group, (text, table) in groups.items():
        p = sub.add_parser(group, help=text, description=text)
        gsub = p.add_subparsers(dest=group, required=True, metavar=group.upper())
        for name, (module, help_text) in table.items():
            _add(gsub, name, module, help_text, words[:2] == [group, name])
    return ap


def main(argv: list[str] | None = None, **tables) -> int:
    """Run one command line (default sys.argv); `tables` as build_parser's (prog, description, commands, groups)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    keep_freed_memory()             # the studies' kernels allocate megabytes per call: reuse, do not fault in again
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    try:                            # the command's module is imported here: a Ctrl-C may come meanwhile
        parser = build_parser(argv, **tables)
        if not argv:
            parser.print_help(sys.stderr)
            return Exit.USAGE
        args = parser.parse_args(argv)
    except SystemExit as exc:       # --help (0) or a bad command line (Exit.USAGE), already printed
        return int(exc.code or 0)
    except KeyboardInterrupt:
        print(f"{tables.get('prog', 'carav')}: interrupted", file=sys.stderr)
        return Exit.INTERRUPTED
    prog = parser.prog
    args.argv = argv                # the command as given, for records that say how they were made
    name = " ".join(w for w in (args.command, getattr(args, args.command, None)) if isinstance(w, str))
    try:
        code = int(args.func(args))
        sys.stdout.flush()          # a closed pipe shows here, not in the interpreter's last flush
        return code
    except BrokenPipeError:         # the reader went away (`carav blocks | head`): stop quietly
        _silence_stdout()
        return Exit.INTERRUPTED
    except CommandError as exc:
        print(f"{prog} {name}: {exc}", file=sys.stderr)
        return int(exc.code)
    except KeyboardInterrupt:
        print(f"{prog} {name}: interrupted", file=sys.stderr)
        return Exit.INTERRUPTED
    except Exception as exc:        # one line for the user; the traceback with --debug
        if debug:
            raise
        print(f"{prog} {name}: failed: {type(exc).__name__}: {exc} (--debug shows the traceback)", file=sys.stderr)
        return Exit.FAILED


def entry() -> int:
    """The `carav` program (its console script, and `python -m carav_stream.cli`): main, then a short exit. The
    objects left are frozen out of the collector (gc.freeze), so that the interpreter's exit does not walk the
    object graph of numpy, scipy and ZeroMQ once more, a fifth of their import's time; what is left at exit is
    freed as before, but for objects in reference cycles, whose finalizers Python does not promise to run at exit
    anyway. Not in main itself: the tests call main in their own process, which lives on."""
    code = main()
    gc.freeze()
    return code


def _silence_stdout() -> None:
    """Point standard output at /dev/null, so that the interpreter's flush at exit meets no closed pipe."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)
