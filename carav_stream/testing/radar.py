"""The radar graph with your block in place of a built-in one, and what must hold of it.

    path = radar_graph(graphs, {"detector": {"type": "my_detector", "eta": 1.5}}, block_paths=[MY_BLOCKS])
    run = graphs.run(path, "--cycles", "300", sets={"seed": 5})
    assert run.wait() == 0
    check_fail_closed(graphs.workdir)                       # no cycle reached ranging without a clean verdict
    k, n = false_alarms(graphs.workdir)                     # alarms on attack-free cycles
    assert_rate_at_most(k, n, 1e-3)                         # within what the design allows, at 99 % confidence
    assert_equals_algorithm1(graphs.workdir, run_algorithm1(scene_of("table1"), 300, seed=5, ...))

`radar_graph` writes a graph that includes the shipped graphs/radar_chain.toml, replaces the nodes you name (your
block must have the ports of the node it replaces) and taps the detector's verdicts, the cycles that reached ranging
and the cycles the gate refused into jsonl files of the working folder (`verdicts.jsonl`, `judged.jsonl`).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from carav_graphs import graph_file
from carav_stream.testing.graphs import Graphs, by_cycle, read_jsonl

__all__ = ["radar_graph", "verdicts", "ranged_cycles", "check_fail_closed", "false_alarms", "assert_rate_at_most",
           "assert_equals_algorithm1", "VERDICTS", "JUDGED"]

VERDICTS, JUDGED = "verdicts.jsonl", "judged.jsonl"
TAPS = ["detector.verdict -> vlog.inp", "ranging.estimates -> elog.inp", "gate.alarms -> elog.extra"]


def _inline(values: dict[str, Any]) -> str:
    """A TOML inline table."""
    return "{ " + ", ".join(f"{k} = {json.dumps(v)}" for k, v in values.items()) + " }"


def radar_graph(graphs: Graphs, replace: dict[str, dict[str, Any]] | None = None, *,
                block_paths: list[str | Path] = (), name: str = "radar.toml", base: str | Path | None = None,
                remove_connections: list[str] = (), connections: list[str] = ()) -> Path:
    """A graph file in the working folder: the radar chain (graphs/radar_chain.toml, or `base`), the nodes of
    `replace` replaced, changed or added ({node: {"type": ..., params}}; without "type": the included node's block
    with other parameters; another model starts from its defaults), `remove_connections` of the chain removed and
    `connections` added (a block spliced into the chain: remove "channel.rx -> adc.rx", add "channel.rx ->
    my.inp" and "my.out -> adc.rx"), and taps of the verdicts and the judged cycles. Cycles until stopped unless
    --cycles."""
    base = Path(base) if base else graph_file("radar_chain")
    blocks = {node: _inline(values) for node, values in (replace or {}).items()}
    blocks["vlog"] = _inline({"type": "jsonl_sink", "path": VERDICTS, "max_values": 100000})
    blocks["elog"] = _inline({"type": "jsonl_sink", "path": JUDGED})
    removed = [f"remove_connections = {json.dumps(list(remove_connections))}"] if remove_connections else []
    body = "\n".join([f"include = {json.dumps(str(base))}", *removed,
                      f"connections = {json.dumps([*TAPS, *connections])}", "", "[run]", "cycles = 0", "",
                      "[blocks]", *(f"{node} = {table}" for node, table in blocks.items()), ""])
    return graphs.graph(body, name, block_paths=block_paths)


def verdicts(workdir: str | Path) -> dict[int, dict]:
    """{cycle: the detector's verdict for it} (alarm, invalid, q, ... as the verdict's per-cycle columns give)."""
    return by_cycle(read_jsonl(Path(workdir) / VERDICTS))


def ranged_cycles(workdir: str | Path) -> dict[int, dict]:
    """{cycle: its estimates} for every cycle that reached ranging."""
    return by_cycle([r for r in read_jsonl(Path(workdir) / JUDGED) if r.get("port") == "inp"])


def check_fail_closed(workdir: str | Path) -> tuple[int, int]:
    """No cycle reached ranging without a verdict for that cycle that says alarm False and invalid False in so many
    words (Algorithm 1, steps 5-6). Returns (cycles ranged, cycles judged)."""
    judged, ranged = verdicts(workdir), ranged_cycles(workdir)
    missing = sorted(set(ranged) - set(judged))
    assert not missing, f"cycles {missing[:10]} reached ranging without a verdict"
    unclean = [c for c in ranged if not (judged[c].get("alarm") is False and judged[c].get("invalid") is False)]
    assert not unclean, f"cycles {unclean[:10]} reached ranging with verdicts " \
                        f"{[{k: judged[c].get(k) for k in ('alarm', 'invalid')} for c in unclean[:3]]}"
    return len(ranged), len(judged)


def false_alarms(workdir: str | Path) -> tuple[int, int]:
    """(cycles the detector alarmed on, cycles it judged), from its verdicts: on an attack-free run, false alarms."""
    judged = verdicts(workdir)
    return sum(v.get("alarm") is True for v in judged.values()), len(judged)


def assert_rate_at_most(k: int, n: int, rate: float, confidence: float = 0.99) -> None:
    """k events in n trials are consistent with a rate of at most `rate`: the one-sided binomial test does not reject
    it at `confidence` (P(X >= k) under Binomial(n, rate) is above 1 - confidence)."""
    assert n > 0, "no trials"
    p = stats.binom.sf(k - 1, n, rate)
    assert p > 1 - confidence, f"{k} in {n} is more than a rate of {rate:g} allows (p = {p:.3g})"


def assert_equals_algorithm1(workdir: str | Path, lib: Any) -> None:
    """The graph's per-cycle Q, verdicts and estimates equal `lib` (a run_algorithm1 result for the same scene,
    cycles, seed, fidelity, batch and attacker) bit for bit: your block is a true replacement."""
    judged = verdicts(workdir)
    n = len(lib.q)
    assert sorted(judged) == list(range(n)), f"verdicts for cycles {sorted(judged)[:5]}..., expected 0..{n - 1}"
    np.testing.assert_array_equal([judged[c]["q"] for c in range(n)], lib.q, err_msg="Q per cycle")
    np.testing.assert_array_equal([judged[c]["alarm"] for c in range(n)], lib.alarm, err_msg="alarms")
    est = ranged_cycles(workdir)
    assert sorted(est) == [c for c in range(n) if not lib.alarm[c]], "the cycles that reached ranging"
    np.testing.assert_array_equal([est[c]["range_m"][0] for c in sorted(est)], lib.range_m[~lib.alarm, 0],
                                  err_msg="range estimates")
    np.testing.assert_array_equal([est[c]["velocity_mps"][0] for c in sorted(est)], lib.velocity_mps[~lib.alarm, 0],
                                  err_msg="velocity estimates")
