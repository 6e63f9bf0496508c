"""A data plane is one module: the toy plane (tests/runtime/planes/toy.py: buffers appended to a file per port,
read back with pread), found through CARAV_PLANE_PATH and named by the graph's run.transport, carries the demo
graph to the summary the inline plane gives, with no other file of the project naming it."""
import os

import pytest

from carav_stream.testing.graphs import Graphs
from tests.integration.conftest import ROOT

PLANES = ROOT / "tests" / "runtime" / "planes"
TIMING = {"run", "wall_s", "throughput_cycles_per_s", "real_time_factor", "transport"}   # differ from run to run
NODE_TIMING = {"busy_s", "cpu_s", "cpu_working_s"}
# a node that merges its inputs (run_summary) takes frames in the order they arrive: the seqs its block began and
# ended with depend on timing
ARRIVAL = {"first_seq", "next_seq"}


def _counts(summary: dict) -> dict:
    """The summary without what depends on time (and the plane's name)."""
    per_node = {n: {**{k: v for k, v in c.items() if k not in NODE_TIMING},
                    "history": [{k: v for k, v in h.items() if k not in ARRIVAL} for h in c["history"]]}
                for n, c in summary["per_node"].items()}
    return {**{k: v for k, v in summary.items() if k not in TIMING}, "per_node": per_node}


@pytest.fixture
def graphs(tmp_path):
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
           "CARAV_PLANE_PATH": str(PLANES), "CARAV_KEEP_RUN_DIR": "1"}    # the run folder stays: the toy's files
    g = Graphs(tmp_path, env=env)
    yield g
    g.close()


def test_a_plane_added_as_one_module_carries_the_demo_graph_to_the_inline_summary(graphs):
    summaries = {}
    for plane in ("zmq", "toy"):
        run = graphs.run(ROOT / "graphs" / "demo.toml", "--cycles", "200", sets={"run.transport": plane})
        assert run.wait() == 0, run.stderr()
        summaries[plane] = run.summary()
    toy = summaries["toy"]
    assert toy["transport"] == "toy" and toy["lost"] == 0 and toy["cycles"] == 200
    assert toy["attacked_cycles"] == 50 and toy["detected"] == 50 and toy["false_alarms"] == 0
    assert _counts(toy) == _counts(summaries["zmq"])
    # the arrays went through the toy's files (a port's frames without arrays leave its file empty)
    files = {p.name: p.stat().st_size for p in graphs.run_root.glob(f"carav-*/{toy['run']}/toy-*")}
    assert all(files.get(f"toy-{port}", 0) > 0 for port in ("source.tx", "channel.rx", "adc.frames")), files
    assert not list(graphs.run_root.glob(f"carav-*/{summaries['zmq']['run']}/toy-*"))   # inline: no file
