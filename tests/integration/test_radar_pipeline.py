"""Algorithm 1 as a graph of real processes: the guarantees of the radar pipeline."""
import csv
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from carav_stream.firmware.algorithm1 import run_algorithm1
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.graph import TRANSPORTS
from carav_stream.testing.graphs import by_cycle, node_pids
from tests.integration.conftest import PACED, exit_code_after_a_kill, read_jsonl, wait_until

pytestmark = pytest.mark.integration

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
TAPS = Path(__file__).resolve().parent / "graphs"


def radar(carav, cycles: int, graph: str = "radar_taps.toml", *, seed: int = 21, fidelity: str = "beat",
          batch: int = 16, **attacker):
    """Run tests/integration/graphs/<graph> (the radar chain with taps) with --set for what the test varies; paced
    when it runs until stopped (cycles 0)."""
    sets = [f"seed={seed}", f"fidelity={fidelity}", f"batch={batch}",
            *(f"attacker.{k}={v!r}" if isinstance(v, str) else f"attacker.{k}={v}" for k, v in attacker.items())]
    return carav.run(TAPS / graph, "--cycles", str(cycles), *sum((["--set", s] for s in sets), []),
                     *(() if cycles else PACED))


def assert_equals_the_library(carav, run, lib, n: int, batch: int = 16) -> dict:
    """The run's per-cycle Q, verdicts, activation rows, estimates and csv rows equal `lib` (run_algorithm1's) bit for
    bit; returns the run's summary."""
    records = read_jsonl(carav.workdir / "verdicts.jsonl")
    assert [(v["seq"], v["cycle"], v["cycles"]) for v in records] == [
        (i, batch * i, min(batch, n - batch * i)) for i in range(-(-n // batch))]
    verdicts = by_cycle(records)
    assert sorted(verdicts) == list(range(n))
    np.testing.assert_array_equal([verdicts[c]["q"] for c in range(n)], lib.q)            # bit for bit
    np.testing.assert_array_equal([verdicts[c]["alarm"] for c in range(n)], lib.alarm)
    np.testing.assert_array_equal(np.concatenate([v["data"] for v in records]), lib.rho)
    est = by_cycle([e for e in read_jsonl(carav.workdir / "judged.jsonl") if e["port"] == "inp"])
    assert sorted(est) == [c for c in range(n) if not lib.alarm[c]]
    np.testing.assert_array_equal([est[c]["range_m"][0] for c in sorted(est)], lib.range_m[~lib.alarm, 0])
    np.testing.assert_array_equal([est[c]["velocity_mps"][0] for c in sorted(est)], lib.velocity_mps[~lib.alarm, 0])
    rows = sorted(csv.DictReader(open(carav.workdir / "cycles.csv")), key=lambda r: int(r["cycle"]))
    assert [int(r["cycle"]) for r in rows] == list(range(n))
    assert [r["port"] == "alarms" for r in rows] == lib.alarm.tolist()
    ranges = [r["range_m"] for r in rows if r["port"] == "estimates"]
    assert ranges == [repr(float(x)) for x in lib.range_m[~lib.alarm, 0]]
    s = run.summary()
    assert s["lost"] == 0 and s["cycles"] == n and s["cycles_judged"] == n
    return s


def assert_data_plane(carav, s: dict) -> None:
    """The run's arrays went over the fixture's data plane: with shm, the ADC's frames in slots, none inline."""
    assert s["transport"] == carav.transport
    if carav.transport == "shm":
        adc = s["shared_memory"]["adc.frames"]
        assert adc["frames_in_slots"] > 0 and adc["frames_inline"] == 0 and adc["segment_bytes"] > 0, adc
    else:
        assert s["shared_memory"] == {}


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_pipeline_equals_the_in_process_library_bit_for_bit(carav):
    n = 120   # 7 frames of 16 cycles and a last one of 8
    run = radar(carav, n, model="smart", rarms=3.0, start_cycle=60)
    assert run.wait() == 0, run.stderr()
    lib = run_algorithm1(scene_of("table1"), n, seed=21, attack="smart",
                         attack_params={"rarms": 3.0, "start_cycle": 60})
    s = assert_equals_the_library(carav, run, lib, n)
    assert s["attacked_cycles"] == 60
    assert s["detected"] == int(lib.alarm[60:].sum()) and s["false_alarms"] == int(lib.alarm[:60].sum())
    assert_data_plane(carav, s)
    if carav.transport == "shm":   # a partly clean frame's clean cycles go straight into the gate's slot
        refused = [int(lib.alarm[a:a + 16].sum()) for a in range(0, n, 16)]
        partly = sum(0 < k < len(lib.alarm[a:a + 16]) for a, k in zip(range(0, n, 16), refused))
        assert partly > 0 and s["shared_memory"]["gate.clean"]["computed_in_place"] == partly, (refused, s)


def assert_attacker_heard_only_the_past_emission(carav, run, n: int, batch: int) -> None:
    rho = np.concatenate([r["data"] for r in read_jsonl(carav.workdir / "rho.jsonl")])
    seen = read_jsonl(carav.workdir / "attacker_inputs.jsonl")   # exactly the frames sent to the attacker
    assert len(seen) == -(-n // batch)
    forbidden = {"rho", "activation", "tx", "active_chirps", "per_cycle"}
    heard = []
    for frame in seen:
        assert not forbidden & set(frame), frame.keys()
        assert [a[0] for a in frame["arrays"]] == ["data"] and frame["air_cycle"] == frame["cycle"] - 1
        heard.extend(frame["data"])
    assert heard[0] == [False] * 64
    for c in range(1, n):
        assert heard[c] == rho[c - 1].tolist()   # cycle c hears cycle c - 1: one cycle late, never current
    s = run.summary()
    assert set(s["per_node"]["attacker"]["in"]) == {"air"}   # its one input: nothing of the received signal


def test_attacker_receives_no_activation_sequence_only_the_past_emission(carav):
    n = 40
    run = radar(carav, n, model="lfsr_predictor", rarms=3.0, batch=8)
    assert run.wait() == 0, run.stderr()
    assert_attacker_heard_only_the_past_emission(carav, run, n, batch=8)


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_reactive_repeater_gated_at_the_receiver_equals_the_library_and_never_hears_rho(carav, fidelity):
    n = 40   # frames of 16, 16 and 8 cycles: on from cycle 8 to 31, silent throughout the last frame
    params = {"rarms": 3.0, "distance_m": 20.0, "latency_s": 2e-7, "start_cycle": 8, "n_active_cycles": 24}
    run = radar(carav, n, seed=25, fidelity=fidelity, model="reactive", **params)
    assert run.wait() == 0, run.stderr()
    lib = run_algorithm1(scene_of("table1"), n, seed=25, attack="reactive", attack_params=params, fidelity=fidelity)
    assert lib.attack_active.tolist() == [8 <= c < 32 for c in range(n)]
    s = assert_equals_the_library(carav, run, lib, n)
    judged = by_cycle(read_jsonl(carav.workdir / "judged.jsonl"))
    assert [judged[c]["attack_active"] for c in range(n)] == lib.attack_active.tolist()
    assert [judged[c]["attack_model"] for c in range(n)] == ["reactive"] * n
    assert s["attacked_cycles"] == 24
    assert_attacker_heard_only_the_past_emission(carav, run, n, batch=16)


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_no_frame_reaches_ranging_without_a_clean_verdict_even_when_the_detector_dies(carav):
    run = radar(carav, 0, "radar_taps_detector_restarts.toml", seed=22, batch=4)
    judged = carav.workdir / "judged.jsonl"
    _kill_mid_run_and_stop(carav, run, "detector", judged)
    run.wait()
    err = run.stderr()
    assert "node 'detector' (rms_detector) failed: exited with signal SIGKILL" in err
    verdicts = by_cycle(read_jsonl(carav.workdir / "verdicts.jsonl"))
    records = read_jsonl(judged)
    estimates = by_cycle([r for r in records if r["port"] == "inp"])
    alarms = by_cycle([r for r in records if r["port"] == "extra"])
    assert estimates and all(verdicts[c]["alarm"] is False for c in estimates if c in verdicts)
    assert all(r["verdict"] == "clean" for r in estimates.values())
    # the log is a second consumer of the detector's verdicts: a detector killed between its two sends has given
    # the gate one frame's verdicts (batch 4) that never reached the log; nothing else may be missing there
    assert len([c for c in estimates if c not in verdicts]) <= 4
    # a verdict lost on the gate's edge when the detector died (its tap may still have it) means a refusal
    assert {a["reason"] for a in alarms.values()} <= {"no_verdict", "no_rho", "no_frame", "attack"}
    s = run.summary()
    assert s["restarts"] == 1 and s["estimated_counts"] == ["detector"]   # SIGKILLed: no final report
    # every generated cycle is judged exactly once: estimated on a clean verdict, or refused with a reason
    assert not set(estimates) & set(alarms) and sorted([*estimates, *alarms]) == list(range(s["cycles"]))


def test_a_crashed_detector_reads_as_refusals_never_as_detections_or_false_alarms(carav):
    """The detector raises on frame seq 3 and stays down: cycles 0-23 carry its own verdicts, cycles 24-63 are
    refused for want of one. The attack is on for cycles 8-31, so the refusals hold 8 attacked and 32 clean cycles:
    counted as verdicts they would read as 24 of 24 attacks detected and 32 false alarms in 40 clean cycles."""
    n, batch = 64, 8
    params = {"rarms": 3.0, "start_cycle": 8, "n_active_cycles": 24}
    run = radar(carav, n, "radar_taps_detector_crashes.toml", seed=26, batch=batch, model="smart", **params)
    assert run.wait() == 1, run.stderr()                                  # a node failed: the run fails
    assert "RuntimeError: deliberate detector crash at seq 3" in run.stderr()
    lib = run_algorithm1(scene_of("table1"), n, seed=26, attack="smart", attack_params=params)
    judged = 3 * batch                                                       # the detector's verdicts: seq 0-2
    assert sorted(by_cycle(read_jsonl(carav.workdir / "verdicts.jsonl"))) == list(range(judged))
    attacked = lib.attack_active
    assert attacked.tolist() == [8 <= c < 32 for c in range(n)]
    s = run.summary()
    assert s["cycles"] == n and s["cycles_judged"] == n and s["failures"]
    assert s["attacked_cycles"] == 24
    assert s["detected"] == int((lib.alarm & attacked)[:judged].sum())
    assert s["missed"] == int((~lib.alarm & attacked)[:judged].sum())
    assert s["false_alarms"] == int((lib.alarm & ~attacked)[:judged].sum())
    assert s["detection_rate"] == s["detected"] / 16 and s["false_alarm_rate"] == s["false_alarms"] / 8
    assert s["refused"] == {"cycles": n - judged, "by_reason": {"no_verdict": n - judged}, "attacked_cycles": 8}
    out = run.stdout()
    assert "attacked cycles 24, 16 judged by the detector: detected" in out
    assert f"false alarms {s['false_alarms']} on 8 clean cycles judged" in out
    assert "refused without a verdict (fail closed): 40 cycles (no_verdict 40; 8 of them attacked)" in out
    assert "None" not in out


@pytest.mark.parametrize("victim,carav", [
    *((v, "zmq") for v in ("source", "channel", "attacker", "adc", "gate", "ranging", "summary")),
    *((v, "shm") for v in ("channel", "gate"))], indirect=["carav"])   # a producer computing in its slots; a
    # consumer of a fanned-out port that produces into its own segment too
def test_a_killed_radar_node_is_restarted_and_the_graph_goes_on_in_order_without_stalling(carav, victim):
    """SIGKILL one node mid-run: after its restart every later cycle is judged once, in order (no sink rejects a
    duplicate or out-of-order frame), what died with it is counted, and `carav stop` drains well within its
    deadline (the nodes pairing inputs get told where each stream resumes instead of waiting for lost frames).

    Every case takes a different resume path, so none is left out: the source resumes beyond its lease; channel's
    loss reaches adc's pairing on both its inputs, the attacker's on one; adc's fans out to two nodes that pair
    with each other downstream (detector and gate); the gate's loss reaches the summary's pairing on both its
    inputs, ranging's on one; the summary is the sink. The shared-memory cases are the comment's above."""
    run = radar(carav, 0, "radar_taps_restart.toml", seed=24, batch=4)
    judged = carav.workdir / "judged.jsonl"
    n_at_restart = _kill_mid_run_and_stop(carav, run, victim, judged)
    code = run.wait()
    s = run.summary()
    assert s["restarts"] == 1 and s["estimated_counts"] == [victim] and not s["failures"], s["failures"]
    assert code == exit_code_after_a_kill(s, victim), run.stderr()
    rejects = [line for line in run.stderr().splitlines() if "rejected frame" in line]
    if victim == "source":
        # the restarted source resumes beyond its killed incarnation's lease, so no seq ever has two contents;
        # frames of the killed incarnation still queued when the new one's arrive are refused, never mixed in
        assert all("duplicate or out of order" in line for line in rejects), rejects
    else:
        assert s["rejected"] == 0 and not rejects, run.stderr()
    records = read_jsonl(judged)
    seqs = [r["seq"] for r in records if r["port"] == "inp"]
    assert seqs == sorted(set(seqs))
    estimates = by_cycle([r for r in records if r["port"] == "inp"])
    alarms = by_cycle([r for r in records if r["port"] == "extra"])
    assert not set(estimates) & set(alarms) and len(estimates) + len(alarms) > n_at_restart
    assert all(r["verdict"] == "clean" for r in estimates.values())


@pytest.mark.parametrize("victim,carav", [
    *((v, "zmq") for v in ("source", "attacker", "gate", "summary")), ("gate", "shm")], indirect=["carav"])
def test_a_node_stopped_and_continued_costs_nothing(carav, victim):
    """SIGSTOP one node for a second (shorter than the heartbeat timeout), then SIGCONT: the graph waits for it
    (bounded queues), nothing is restarted, lost or judged twice, and every cycle is judged in order.

    A stopped node runs no code; what differs between victims is which queues fill and which pairing waits. One
    victim per such position: the source (the generator and its cycle lease; both its outputs starve), the
    attacker (one branch of a fan-out: the other branch fills while adc's pairing waits), the gate (a node pairing
    two inputs: both producers back up) and the summary (the sink: the whole chain backs up), and the gate again
    on shared memory (its slots stay held while it is stopped). Left out as the same position again: channel (one
    input, a fan-out like the source's), adc and detector (pairing two inputs, like the gate), ranging (one input,
    one output, like the attacker)."""
    run = radar(carav, 0, seed=26, batch=4)
    judged = carav.workdir / "judged.jsonl"
    wait_until(lambda: len(read_jsonl(judged)) > 30, "cycles to be judged", run)
    pid = int(wait_until(lambda: _pid_of(carav, run, victim), f"{victim} pid", run))
    os.kill(pid, signal.SIGSTOP)
    try:
        time.sleep(1.0)
    finally:
        os.kill(pid, signal.SIGCONT)
    n = len(read_jsonl(judged))
    wait_until(lambda: len(read_jsonl(judged)) > n + 30, "cycles after SIGCONT", run)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["restarts"] == 0 and s["lost"] == 0 and s["rejected"] == 0 and not s["failures"]
    records = by_cycle(read_jsonl(judged))
    assert sorted(records) == list(range(s["cycles"])) and s["cycles_judged"] == s["cycles"]


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_a_killed_supervisor_takes_its_nodes_and_leaves_nothing_behind(carav):
    """SIGKILL the supervisor itself: its nodes notice (parent-death signal) and exit; the next carav command
    removes the run folder it could not remove (endpoints, specs, logs), no frame was judged without a
    clean verdict meanwhile, and nothing of the run is left in /dev/shm or in memory (its segments are
    anonymous: freed with the last process that held them)."""
    shm_before = _dev_shm()
    run = radar(carav, 0, seed=27, batch=4)
    judged = carav.workdir / "judged.jsonl"
    wait_until(lambda: len(read_jsonl(judged)) > 30, "cycles to be judged", run)
    [folder] = list(carav.run_root.glob("carav-*/*"))
    nodes = _node_pids(carav)
    assert len(nodes) == len(list(folder.glob("*.spec"))) > 1   # every node's process
    pids = [run.proc.pid, *nodes]
    if carav.transport == "shm":
        assert _segments_held_by(pids) >= 1                       # the run's data does travel in segments
    assert not _dev_shm_held_by(pids)                             # none of it has a name
    os.kill(run.proc.pid, signal.SIGKILL)
    run.proc.wait()                    # SIGKILL: it ends and is reaped
    wait_until(lambda: not run.group_alive(), "every node of the killed supervisor to exit", run)
    assert _dev_shm() <= shm_before
    assert all(not Path(f"/proc/{pid}").exists() for pid in pids)   # ... so no process holds a segment
    assert folder.exists()                                        # nobody could clean up yet ...
    assert carav.cli("status").returncode == 0                   # ... the next command does
    assert not folder.exists() and not list(carav.run_root.glob("carav-*/*"))
    estimates = [r for r in read_jsonl(judged) if r["port"] == "inp"]
    assert estimates and all(r["verdict"] == "clean" for r in estimates)


def _node_pids(carav, node: str = "*") -> list[int]:
    return node_pids(carav.run_root, node)


def _dev_shm() -> set[str]:
    """The names in /dev/shm, but Python multiprocessing's semaphores (sem.mp-*), which tests running beside this
    one make (a Dask cluster's workers) and carav, which does not use multiprocessing, never does."""
    return {n for n in os.listdir("/dev/shm") if not n.startswith("sem.mp-")}


def _dev_shm_held_by(pids: list[int]) -> set[str]:
    """Files under /dev/shm open or mapped in these processes."""
    held = set()
    for pid in pids:
        targets = []
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                targets.append(os.readlink(fd))
            except OSError:
                continue
        maps = Path(f"/proc/{pid}/maps").read_text().splitlines()
        targets += [line.split(maxsplit=5)[5] for line in maps if len(line.split(maxsplit=5)) == 6]
        held |= {t for t in targets if t.startswith("/dev/shm/")}
    return held


def _segments_held_by(pids: list[int]) -> int:
    """Shared-memory segments (memfd) open in these processes."""
    held = set()
    for pid in pids:
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("/memfd:carav-"):
                held.add(target)
    return len(held)


def _kill_mid_run_and_stop(carav, run, victim: str, judged) -> int:
    """Once 30 records are judged, SIGKILL `victim`; once the supervisor has restarted it and 30 more records are
    judged, `carav stop`. Returns the number of records judged when the restart was reported."""
    wait_until(lambda: len(read_jsonl(judged)) > 30, "cycles to be judged", run)
    os.kill(int(wait_until(lambda: _pid_of(carav, run, victim), f"{victim} pid", run)), signal.SIGKILL)
    wait_until(lambda: f"restarting {victim!r}" in run.stderr(), f"the supervisor to restart {victim}", run)
    n_at_restart = len(read_jsonl(judged))
    wait_until(lambda: len(read_jsonl(judged)) > n_at_restart + 30, "cycles after the restart", run)
    assert carav.cli("stop").returncode == 0
    return n_at_restart


def _pid_of(carav, run, node):
    pids = _node_pids(carav, node) if run.proc.poll() is None else []
    return pids[0] if len(pids) == 1 else None


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_live_attacker_swaps_keep_every_cycle_and_change_the_verdicts(carav):
    run = radar(carav, 0, seed=23, fidelity="waveform", batch=4)
    judged = carav.workdir / "judged.jsonl"
    swaps = [("smart", ["rarms=4.0"]),
             ("secondary_antenna", ["range_m=30.0", "velocity_mps=13.89", "tx_power_w=0.1"])]
    for i, (model, sets) in enumerate(swaps):
        wait_until(lambda: len(by_cycle(read_jsonl(judged))) > 30 * (i + 1), f"cycles before swap {i}", run)
        res = carav.cli("swap", "attacker", "attacker", "--set", f"model={model}",
                        *sum((["--set", s] for s in sets), []))
        assert res.returncode == 0, res.stderr
    wait_until(lambda: len(by_cycle(read_jsonl(judged))) > 100, "cycles after the last swap", run)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    records = by_cycle(read_jsonl(judged))
    assert sorted(records) == list(range(s["cycles"]))     # none lost, duplicated or reordered
    assert s["lost"] == 0
    models = [records[c].get("attack_model") for c in sorted(records)]
    firsts = [4 * sw["first_seq"] for sw in s["swaps"]]     # frames of 4 cycles: swaps fall between frames
    assert models == ["none"] * firsts[0] + ["smart"] * (firsts[1] - firsts[0]) + \
        ["secondary_antenna"] * (s["cycles"] - firsts[1])
    alarmed = [records[c]["port"] == "extra" for c in sorted(records)]
    assert not any(alarmed[:firsts[0]])                                   # clean before the first swap
    assert all(alarmed[firsts[0]:])                                       # every attacked cycle alarms


def test_demo_graph_runs_and_reports_detection_figures(carav):
    run = carav.run(GRAPHS / "demo.toml", "--cycles", "200")
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["cycles"] == 200 and s["lost"] == 0 and s["cycles_judged"] == 200
    assert s["attacked_cycles"] == 50 and s["detected"] == 50 and s["false_alarms"] == 0
    assert s["range_error_m"]["n"] == 150 and s["range_error_m"]["rmse"] < 0.05
    out = run.stdout()
    assert "(detection rate 100 %)" in out and "frames lost 0" in out and "None" not in out


def test_a_paced_source_waits_for_its_release_and_still_stops_at_once(carav):
    """One cycle a frame at 0.001 cycles a second: the first frame goes at once, the next is due in 1000 s. The
    runtime generates nothing before its release (the run holds one cycle) and serves control while it waits (the
    stop ends the run; it would wait 1000 s for the release otherwise, and the run outlive the test's cap)."""
    run = carav.run(TAPS / "radar_taps.toml", "--set", "batch=1", "--set", "source.cycles_per_s=0.001")
    wait_until(lambda: read_jsonl(carav.workdir / "judged.jsonl"), "the first cycle to be judged", run)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["cycles"] == 1 and s["cycles_judged"] == 1 and s["lost"] == 0


def _free_port_base() -> int:
    import socket
    for _ in range(50):
        with socket.socket() as a:
            a.bind(("127.0.0.1", 0))
            base = a.getsockname()[1]
        if 1024 <= base <= 64000:
            ok = True
            for p in range(base, base + 4):
                with socket.socket() as b:
                    try:
                        b.bind(("127.0.0.1", p))
                    except OSError:
                        ok = False
            if ok:
                return base
    raise RuntimeError("no free port range")


@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)
def test_two_hosts_over_tcp_as_two_supervisors(carav):
    keys = carav.cli("keys", str(carav.workdir / "keys"))    # a graph run in parts needs keys of its own
    assert keys.returncode == 0, keys.stderr
    path = carav.workdir / "two.toml"     # graphs/two_hosts.toml on free ports, with the [security] table printed
    path.write_text(f'include = "{GRAPHS / "two_hosts.toml"}"\n[hosts.front]\nport_base = {_free_port_base()}\n'
                    f'[hosts.back]\nport_base = {_free_port_base()}\n{keys.stdout}')
    back = carav.run(path, "--host", "back", "--cycles", "200")
    front = carav.run(path, "--host", "front", "--cycles", "200")
    assert front.wait() == 0, front.stderr()
    assert back.wait() == 0, back.stderr()
    sb, sf = back.summary(), front.summary()
    assert sf["cycles"] == 200 and set(sf["per_node"]) == {"source", "channel", "attacker", "adc"}
    assert sb["cycles"] == 200 and sb["cycles_judged"] == 200 and sb["lost"] == 0
    assert sb["attacked_cycles"] == 50 and sb["detected"] == 50 and sb["false_alarms"] == 0
    if carav.transport == "shm":   # same-host ports in shared memory; the adc's, feeding the other host, inline
        assert sf["shared_memory"]["channel.rx"]["frames_in_slots"] > 0 and "adc.frames" not in sf["shared_memory"]
        assert sb["shared_memory"]["gate.clean"]["frames_in_slots"] > 0

