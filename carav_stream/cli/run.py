"""`carav run GRAPH`: validate a graph, run it (one process per block) and print its summary."""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from carav_stream.console.errors import CommandError, Exit, fail
from carav_stream.console.options import count, output_file
from carav_stream.console.progress import ProgressBar
from carav_stream.runtime import planes
from carav_stream.runtime.launcher import Launcher

if TYPE_CHECKING:
    from carav_stream.runtime.graph import Graph


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("graph", type=graph_file)
    run_options(p)
    p.add_argument("--view", action="store_true", help="watch the run in a browser: a live_view node on taps of "
                   "the gate and the estimator serves a page (a tap never slows the chain)")
    p.add_argument("--port", type=count(0), default=5006, help="the --view page's TCP port (default 5006; 0 = any "
                   "free port)")
    p.add_argument("--view-host", default="127.0.0.1", help="the --view page's address (default loopback only)")


def graph_file(text: str) -> Path:
    """A graph file that exists (argparse refuses any other in one line naming the argument: exit 2, usage)."""
    path = Path(text)
    if not path.is_file():
        what = "is a folder, not a graph file" if path.is_dir() else "no such file"
        raise argparse.ArgumentTypeError(f"{text}: {what}")
    return path


def run_options(p: argparse.ArgumentParser) -> None:
    """The options of `carav run` (shared by `carav record` and `carav replay`)."""
    p.add_argument("--cycles", type=count(0), help="cycles each source generates (a frame may carry several; default: "
                   "the graph's run.cycles; 0 = until stopped)")
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                   help="override a node's parameter, a graph-wide one with PARAM=VALUE, a [run] setting with "
                   "run.KEY=VALUE")
    p.add_argument("--json", type=output_file, metavar="FILE", help="write the summary as JSON")
    p.add_argument("--mat", type=output_file, metavar="FILE", help="write the summary as a MATLAB file (v5), the "
                   "struct `summary` (as carav export makes of the JSON)")
    p.add_argument("--transport", choices=planes.names(), help="data plane of same-host edges: zmq (arrays in "
                   "ZeroMQ messages) or shm (arrays in shared memory, headers over ZeroMQ); default: the graph's "
                   "run.transport, else zmq")
    p.add_argument("--host", help="run only the nodes placed on this host (graphs with [hosts])")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR", help="extra folder of block files")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="live progress line (default: on a terminal; redirected, a line every 10 s with the time "
                   "left, for a run of a known number of cycles)")


def run(args: argparse.Namespace) -> int:
    # first, before this command imports anything heavy: the zygote that will fork the nodes imports what they
    # need while the graph is read and validated
    launcher = Launcher()
    try:
        graph = load(args.graph, args, launcher=launcher)
        return execute(graph, args, launcher=launcher) if not args.view else _viewed(graph, args, launcher)
    finally:
        launcher.close()


def _viewed(graph: Graph, args: argparse.Namespace, launcher: Launcher) -> int:
    """Run `graph` with a live_view node on its taps (--view)."""
    # start-up time: the view's modules, for the runs that ask for it
    from carav_stream.cli.view import view_graph
    from carav_stream.view.server import free_port, new_token, page_url

    port = args.port or free_port(args.view_host)
    token = new_token()
    path = view_graph(graph, args.view_host, port, token)
    try:
        viewed = load(path, args, shown_as=args.graph, launcher=launcher)
        print(f"carav run: live view at {page_url(args.view_host, port, token)}", file=sys.stderr, flush=True)
        return execute(viewed, args, launcher=launcher)
    finally:
        shutil.rmtree(path.parent, ignore_errors=True)


def load(path: Path, args: argparse.Namespace, overrides: list[str] = (), shown_as: Path | None = None,
         launcher: Launcher | None = None) -> Graph:
    """The graph file with `overrides`, then the command line's --set and --cycles; CommandError if invalid. The
    `launcher`'s zygote is told the graph's block types as soon as they are read, to import them meanwhile; the
    blocks' param_warnings() are left for later: the run's supervisor runs them while the nodes start, before
    any frame flows (execute)."""
    # start-up time: validation imports the blocks (numpy, scipy), after `run` started its zygote
    from carav_stream.runtime.graph import GraphError
    from carav_stream.runtime.loader import load_graph

    cycles = [] if args.cycles is None else [f"run.cycles={args.cycles}"]   # checked like the file's value
    plane = [] if args.transport is None else [f"run.transport={args.transport}"]
    try:
        return load_graph(path, [*overrides, *args.set, *cycles, *plane], args.blocks,
                          on_types=launcher.import_blocks if launcher is not None else None, checks_later=True)
    except GraphError as exc:
        raise invalid_graph(shown_as or path, exc.problems) from None


def invalid_graph(path: Path, problems: list[str]) -> CommandError:
    """The refusal of an invalid graph file: its path, then every problem on a line of its own (exit code 3)."""
    return CommandError(f"{path} is not valid:\n" + "\n".join(f"  {p}" for p in problems), Exit.INVALID)


def execute(graph: Graph, args: argparse.Namespace, command: str = "run", expected_cycles: int | None = None,
            launcher: Launcher | None = None) -> int:
    """Run a loaded graph with the options of `carav run` (host, progress, json, mat) and report it; expected_cycles:
    what the progress counts towards when the graph's run.cycles does not say (a replay: the recording's);
    `launcher`: the one started before the graph was loaded, if any (else the supervisor starts its own)."""
    # start-up time: after `run` started its zygote (the supervisor imports ZeroMQ, the summary's writer numpy)
    from carav_stream.console import jsonout
    from carav_stream.runtime.curve_keys import split_run_problem
    from carav_stream.runtime.rundir import RunRootError
    from carav_stream.runtime.supervisor import Supervisor

    if args.host is not None and args.host not in graph.hosts:
        return fail(f"--host {args.host!r}: the graph's hosts are {sorted(graph.hosts)}", Exit.USAGE)
    split = split_run_problem(graph, args.host)
    if split is not None:
        return fail(f"{graph.path.name}: {split}", Exit.INVALID)
    for w in graph.warnings:
        print(f"carav {command}: warning: {w}", file=sys.stderr)
    try:
        lines = _progress_lines(command) if args.progress is None and not sys.stderr.isatty() else None
        sup = Supervisor(graph, host=args.host, progress=args.progress, on_progress=lines,
                         expected_cycles=expected_cycles, launcher=launcher,
                         on_warnings=lambda found: [print(f"carav {command}: warning: {w}", file=sys.stderr)
                                                    for w in found])
    except RunRootError as exc:           # the run folder is not the user's own: nothing started
        raise CommandError(str(exc), Exit.FAILED) from None
    summary = with_radar_time(sup.run())
    if sup.invalid:                       # a block's own checks, run while the nodes started: none was let go
        raise invalid_graph(graph.path, sup.invalid)
    print_summary(summary)
    if args.json:
        jsonout.write(args.json, summary, indent=2)
    if args.mat:
        # start-up time: scipy.io, for the runs that ask for a MATLAB file only
        from carav_stream.console import matout
        matout.write(args.mat, {"summary": jsonout.plain(summary)})
    if summary["failures"]:
        return Exit.FAILED
    if summary["lost"]:
        return fail(f"{summary['lost']} frame(s) lost in transport: {summary['lost_by_edge']}", Exit.FAILED)
    if summary["stopped_by"] == "signal":
        return Exit.INTERRUPTED           # drained and summarised, but not the run that was asked for
    return Exit.OK


def _progress_lines(command: str):
    """A redirected run's progress (a line every 10 s with the time left), its clock started by the first report,
    when the nodes are told to go: their start-up is no part of the rate."""
    bar: ProgressBar | None = None

    def tell(done: int, total: int) -> None:
        nonlocal bar
        bar = bar or ProgressBar(command)
        bar(done, total)
    return tell


def _num(x: Any, digits: int = 3) -> str:
    """A figure rounded to `digits` significant digits; None (nothing measured) as n/a."""
    if x is None:
        return "n/a"
    if isinstance(x, bool) or isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        return f"{x:.0f}" if abs(x) >= 10 ** digits else f"{x:.{digits}g}"   # 2132, not 2.13e+03
    return str(x)


def _qty(x: float | None, unit: str) -> str:
    """A length (unit "m") or speed ("m/s") with its unit, in milli-units below 0.1."""
    if x is None:
        return "n/a"
    return f"{x * 1e3:.3g} m{unit}" if 0 < abs(x) < 0.1 else f"{x:.3g} {unit}"


def _duration(x: float | None) -> str:
    """A time in s, ms or us, 3 significant digits."""
    if x is None:
        return "n/a"
    for scale, unit in ((1.0, "s"), (1e-3, "ms"), (1e-6, "us")):
        if abs(x) >= scale:
            return f"{x / scale:.3g} {unit}"
    return f"{x * 1e9:.3g} ns" if x else "0 s"


def with_radar_time(s: dict[str, Any]) -> dict[str, Any]:
    """The summary with the radar time simulated and the real-time factor, when the graph has a run_summary:
    radar_time_s = cycles x the scene's cycle duration (t_cycle, radar_cycle_duration_s), real_time_factor =
    radar_time_s / wall_s (1 = as fast as the radar itself; above 1, faster)."""
    t_cycle = s.get("radar_cycle_duration_s")
    if t_cycle is None and s.get("radar_cycles_per_s"):
        t_cycle = 1.0 / s["radar_cycles_per_s"]
    if t_cycle is None:
        return s
    radar_time = s["cycles"] * t_cycle
    return {**s, "radar_time_s": radar_time, "real_time_factor": radar_time / s["wall_s"] if s["wall_s"] else None}


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.3g} %"


def _errors(name: str, e: dict, unit: str) -> str:
    if not e or not e.get("n"):
        return f"  {name}: n/a (no estimate)"
    return (f"  {name}: RMSE {_qty(e['rmse'], unit)}, mean {_qty(e['mean'], unit)}, absolute maximum "
            f"{_qty(e.get('abs_max', e.get('max')), unit)} over {e['n']} cycles")


def _plain(value: Any) -> str:
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_plain(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_plain(v) for v in value) + "]"
    return _num(value, 4)


RADAR_KEYS = {"cycles_judged", "alarms", "alarm_reasons", "raised_by", "attacked_cycles", "detected", "missed",
              "false_alarms", "detection_rate", "false_alarm_rate", "refused", "radar_cycles_per_s",
              "radar_cycle_duration_s", "radar_time_s", "real_time_factor",
              "range_error_m", "range_error_attacked_missed_m", "velocity_error_mps", "velocity_ambiguous",
              "unambiguous_velocity_mps", "velocity_error_modulo_ambiguity_mps", "azimuth_error_deg", "target_list",
              "refused_by_estimator", "unreadable_cycles", "figures_cover", "tracks", "attacker_direction"}
RUNTIME_KEYS = {"graph", "run", "host", "cycles", "lost", "lost_by_edge", "rejected", "unpaired", "restarts",
                "failures", "swaps", "refused_swaps", "stopped_by", "wall_s", "throughput_cycles_per_s", "per_node",
                "estimated_counts", "skipped_by_taps", "transport", "shared_memory", "security", "node_starts"}


def _radar_lines(s: dict[str, Any]) -> list[str]:
    """The run_summary block's figures, as a radar engineer reads them."""
    if "cycles_judged" not in s:
        return []
    lines = []
    if s.get("figures_cover"):        # a restarted run_summary: its figures are not the whole run's
        lines.append(f"  {s['figures_cover']['text']}")
    refused = s.get("refused") or {"cycles": 0, "by_reason": {}, "attacked_cycles": 0}
    judged_clean = s["cycles_judged"] - s["attacked_cycles"] - (refused["cycles"] - refused["attacked_cycles"])
    by = ", ".join(f"{k} {v}" for k, v in sorted(s["raised_by"].items()) if k in ("D0", "D1")) or "none"
    judged_attacked = s["attacked_cycles"] - refused["attacked_cycles"]
    lines.append(f"  attacked cycles {s['attacked_cycles']}, {judged_attacked} judged by the detector: detected "
                 f"{s['detected']}, missed {s['missed']} (detection rate {_pct(s['detection_rate'])})")
    lines.append(f"  false alarms {s['false_alarms']} on {judged_clean} clean cycles judged (false-alarm rate "
                 f"{_pct(s['false_alarm_rate'])}); the detector's alarms raised by {by}")
    reasons = ", ".join(f"{k} {v}" for k, v in sorted(refused["by_reason"].items()))
    lines.append(f"  refused without a verdict (fail closed): {refused['cycles']} cycles"
                 + (f" ({reasons}; {refused['attacked_cycles']} of them attacked)" if refused["cycles"] else ""))
    lines.append(_errors("range error, first target", s.get("range_error_m"), "m"))
    if s.get("range_error_attacked_missed_m", {}).get("n"):
        lines.append(_errors("  of which attacked cycles the detector missed", s["range_error_attacked_missed_m"],
                             "m"))
    lines.append(_errors("velocity error, first target", s.get("velocity_error_mps"), "m/s"))
    if s.get("velocity_ambiguous"):
        v_max = s["unambiguous_velocity_mps"]
        rmse = (s.get("velocity_error_mps") or {}).get("rmse")
        # an estimator that follows the range walk (range_estimator's max_speed_mps) reports the unfolded velocity:
        # its error against the true velocity is then well inside +-v_max; a folded estimate's is about 2 v_max
        unfolded = rmse is not None and rmse < v_max
        lines.append(f"    the target is faster than the unambiguous +-{_qty(v_max, 'm/s')}: " + (
            "the estimates were unfolded, the error above is against the true velocity" if unfolded
            else "the error above is the aliased estimate's"))
        lines.append(_errors("  velocity error modulo the ambiguity", s.get("velocity_error_modulo_ambiguity_mps"),
                             "m/s"))
    azimuth = s.get("azimuth_error_deg")
    if azimuth:
        lines.append(_errors(f"azimuth error, first target only (at {_qty(azimuth['true_azimuth_deg'], 'deg')})",
                             azimuth, "deg")
                     + ("" if azimuth["bound_rms_deg"] is None
                        else f"; its Cramer-Rao std {_qty(azimuth['bound_rms_deg'], 'deg')} (RMS)"))
    for key, text in (("refused_by_estimator", "cycles the estimator refused (no clean verdict)"),
                      ("unreadable_cycles", "cycles whose per-cycle fields could not be read")):
        if s.get(key):
            lines.append(f"  {text}: {s[key]}")
    listing = s.get("target_list")
    if listing:
        for kind in ("clean", "attacked_missed"):
            t = listing.get(kind)
            if not t:
                continue
            where = "clean cycles" if kind == "clean" else "attacked cycles the detector missed"
            per = "; ".join(f"target at {_qty(x['range_m'], 'm')}, {_qty(x['velocity_mps'], 'm/s')}: probability "
                            f"of detection {_pct(x['probability_of_detection'])}" for x in t["targets"])
            lines.append(f"  target list ({listing['detection']}), {t['cycles']} {where}: {per}; false targets "
                         f"{_num(t['false_targets_per_cycle'])} per cycle")
    return lines + _direction_lines(s.get("attacker_direction"))


def _direction_lines(d: dict | None) -> list[str]:
    """The attacker's azimuth the detector estimated (receiver arrays), and the detections in its direction."""
    if not d:
        return []
    why = "; ".join(f"{k} cycles: {_plain(v)}" for k, v in d["cycles_by_reason"].items() if v)
    az = f"median {_num(d['median_azimuth_deg'])} deg, spread (half the IQR) {_num(d['azimuth_spread_deg'])} deg"
    return [f"  attacker's azimuth on {d['attacked_cycles_with_azimuth']} attacked cycles: "
            f"{az if d['attacked_cycles_with_azimuth'] else 'none'} ({why})"] + [
        f"  detections in the attacker's direction, {k} cycles: {f['flagged']} of {f['compared']} compared, on "
        f"{f['cycles_flagged']} cycles" for k, f in (d.get("flagged_detections") or {}).items()]


def _after(a: dict | str | None, what: str) -> str:
    if a == "off":
        return f"{what} off"
    return f"{what} none" if a is None else f"{what} after {a['cycles']} cycles ({a['ms']:.3g} ms)"


def track_lines(t: dict[str, Any]) -> list[str]:
    """The tracker's figures (its summary's "tracks"), as the car's picture of the road reads."""
    unmeasured = ", ".join(f"{k} {v}" for k, v in sorted(t["unmeasured_by_reason"].items()))
    ids = t["false_track_ids"]
    named = f" (ids {', '.join(map(str, ids[:5]))}{', ...' if len(ids) > 5 else ''})" if ids else ""
    gate = t["truth_gate"]
    lines = [f"  tracks: {t['cycles']} cycles tracked, {t['cycles'] - t['measured']} unmeasured"
             + (f" ({unmeasured})" if unmeasured else "")
             + f"; {t['confirmed_tracks']} confirmed, {t['false_tracks']} false{named} (off every target by more "
             f"than {_qty(gate['range_m'], 'm')} or {_qty(gate['velocity_mps'], 'm/s')} while confirmed), "
             f"{t['dragged_tracks']} of them dragged off a target"]
    for x in t["targets"]:
        where = f"  target at {_qty(x['range_m'], 'm')}, {_qty(x['velocity_mps'], 'm/s')}"
        if x["first_held_cycle"] is None:
            lines.append(f"  {where}: never held by a confirmed track")
            continue
        lines.append(f"  {where}: held from cycle {x['first_held_cycle']}: updated {x['held_cycles']} cycles, "
                     f"coasted {x['coasted_cycles']}, lost {x['lost_cycles']}; its tracks deleted "
                     f"{x['deleted_tracks']}")
    if t["first_alarm"] is not None:
        a = t["first_alarm"]
        lines.append(f"    first alarm from the attack's start (cycle {t['attack_start_cycle']}): "
                     f"{_after(a['carav'], 'CARAV')}, {_after(a['nis'], 'NIS alarm')}")
    return lines


def print_summary(s: dict[str, Any]) -> None:
    print(f"graph {s['graph']}  run {s['run']}")
    print(f"  {s['cycles']} cycles in {_duration(s['wall_s'])} of wall time: {_num(s['throughput_cycles_per_s'])} "
          "cycles/s")
    if s.get("radar_time_s") is not None:
        print(f"  real-time factor {_num(s['real_time_factor'])} (radar time / wall time): radar time "
              f"{_duration(s['radar_time_s'])} = {s['cycles']} cycles x the scene's cycle duration "
              f"{_duration(s['radar_cycle_duration_s'])} (radar {_num(s['radar_cycles_per_s'])} cycles/s)")
    print(f"  frames lost {s['lost']}, rejected {s['rejected']}, unpaired {s['unpaired']}; node restarts "
          f"{s['restarts']}")
    for edge, n in (s.get("skipped_by_taps") or {}).items():
        print(f"  frames skipped for a busy observer (a tap, not lost): {n} on {edge}")
    if s.get("transport") == "shm":
        print(f"  {_shared_memory_words(s['shared_memory'])}")
    for line in security_lines(s.get("security") or {}):
        print(f"  {line}")
    for line in _radar_lines(s):
        print(line)
    if s.get("tracks"):
        for line in track_lines(s["tracks"]):
            print(line)
    for k, v in s.items():
        if k not in RUNTIME_KEYS | RADAR_KEYS:
            print(f"  {k.replace('_', ' ')}: {_plain(v)}")
    if s.get("estimated_counts"):
        print(f"  counts estimated from the last heartbeat of: {', '.join(s['estimated_counts'])}")
    print("  node            block              cycles    frames in  frames out  rejected  restarts")
    for n, p in s["per_node"].items():
        print(f"  {n:<15} {p['block']:<18} {p.get('cycles', 0):<9} {sum(p['in'].values()):<10} "
              f"{sum(p['out'].values()):<11} {sum(p['rejected'].values()):<9} {p['restarts']}")
    for sw in s["swaps"]:
        print(f"  {swap_words(sw)}")
    for sw in s.get("refused_swaps", []):
        print(f"  {refused_swap_words(sw)}")
    for f in s["failures"]:
        print(f"  FAILURE: {f}")


def security_lines(sec: dict[str, Any]) -> list[str]:
    """How the run's tcp edges were protected and who was refused, when there is anything to say."""
    lines = []
    if sec.get("tcp") == "curve":
        whose = "keys made for this run" if sec.get("keys") == "run" else "the graph's keys"
        lines.append(f"tcp edges: ZeroMQ CURVE with {whose}")
    lines += [f"WARNING: {w}" for w in sec.get("warnings", [])]
    refused = sec.get("refused_connections") or {}
    if refused:
        lines.append(f"tcp connections refused at the CURVE handshake: {sum(refused.values())} ("
                     + ", ".join(f"{port} {n}" for port, n in refused.items()) + ")")
    control = sec.get("refused_control") or {}
    if control:
        lines.append(f"control messages refused: {sum(control.values())} ("
                     + "; ".join(f"{n} {reason}" for reason, n in list(control.items())[:3])
                     + ("; ..." if len(control) > 3 else "") + ")")
    return lines


def _shared_memory_words(ports: dict[str, dict[str, int]]) -> str:
    """The shared-memory data plane in one line: memory held and where the frames went."""
    total = sum(p["segment_bytes"] for p in ports.values())
    slots = sum(p["frames_in_slots"] for p in ports.values())
    inline = sum(p["frames_inline"] for p in ports.values())
    full = sum(p["no_free_slot"] for p in ports.values())
    biggest = max(ports, key=lambda k: ports[k]["segment_bytes"], default=None)
    where = f" (largest {biggest}: {ports[biggest]['segment_bytes'] / 1e6:.1f} MB)" if biggest else ""
    return (f"shared memory: {total / 1e6:.1f} MB in {len(ports)} segments{where}; frames in slots {slots}, "
            f"inline {inline} (small or larger than a slot; {full} for want of a free slot)")


def swap_words(sw: dict[str, Any]) -> str:
    """A live swap in words: node, block and its version with its model and the parameters the swap set, which
    swap of the node it was, from which frame, when."""
    what = params_words(sw.get("params", {}), sw.get("asked", {}))
    start = (f"cycle {sw['first_cycle']} (frame seq {sw['first_seq']})" if sw.get("first_cycle") is not None
             else f"frame seq {sw['first_seq']}")
    return (f"swap: node {sw['node']} runs block {sw['block']} (version {sw['version']}){' ' + what if what else ''} "
            f"from {start} on, its swap number {sw['generation']}{_when(sw)}")


def refused_swap_words(sw: dict[str, Any]) -> str:
    """A refused swap in words: node, block and parameters asked, when, and why it was refused."""
    what = params_words({}, sw.get("asked", {}))
    return (f"swap refused: node {sw['node']} to block {sw['block']}{' ' + what if what else ''}{_when(sw)}: "
            f"{sw['error']}")


def params_words(applied: dict[str, Any], asked: dict[str, Any]) -> str:
    """'(smart, rarms=3.0)': the model a block runs (applied, or asked) first, then the other parameters asked."""
    model = asked.get("model", applied.get("model"))
    words = ([str(model)] if model is not None else []) + [f"{k}={v}" for k, v in asked.items() if k != "model"]
    return f"({', '.join(words)})" if words else ""


def _when(sw: dict[str, Any]) -> str:
    return f" at {sw['at_s']:.1f} s" if isinstance(sw.get("at_s"), (int, float)) else ""
