"""What a graph's picture writes (graphview/describe.py): a node's own parameters, its variant first, the graph-wide
ones left to the title; a connection's stream from the port declarations; its transport from hosts and data plane."""
from pathlib import Path

from carav_stream.graphview.describe import LABEL_CHARS, MAX_PARAMS, graph_line, node_text, short, stream
from carav_stream.runtime.loader import load_graph

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "graphs" / "demo.toml"


def edge(g, text):
    return next(e for e in g.edges if str(e) == text)


def test_a_node_shows_its_own_parameters_with_units_the_variant_first_and_no_graph_wide_one():
    g = load_graph(DEMO, ["attacker.start_cycle=20", "attacker.rarms=2", "attacker.model=random"])
    lines = node_text(g, "attacker").params
    assert lines[0] == "model = random" and sorted(lines[1:]) == ["rarms = 2", "start_cycle = 20 cycles"], lines
    assert node_text(g, "source").params == ()          # scene, seed and batch are graph-wide: in the title
    assert graph_line(g) == "scene = table1, batch = 32, seed = 7"


def test_past_the_limit_the_parameters_are_counted_and_a_long_value_keeps_its_end():
    g = load_graph(DEMO, ["attacker.range_m=30", "attacker.velocity_mps=5", "attacker.n_active_cycles=10",
                          "attacker.rarms=1", "attacker.model=ghost"])    # five parameters of its own
    lines = node_text(g, "attacker").params
    assert len(lines) == MAX_PARAMS and lines[0] == "model = ghost" and lines[-1] == "+2 more parameters", lines
    assert short("recordings/a_very_long_folder/rec1") == "…ry_long_folder/rec1" and len(short("x" * 50)) == 20
    assert (short(0.5), short(True), short(3)) == ("0.5", "true", "3")


def test_a_stream_is_named_by_the_producing_port_and_wrapped_for_its_label():
    g = load_graph(DEMO)
    rho = stream(g, edge(g, "source.rho -> detector.rho"))
    assert (rho.kind, rho.dtypes, rho.doc, rho.transport, rho.tap) == (
        "rho", "bool", "activation sequences (private: detector only)", "ipc", False)
    assert rho.label == [("rho", "kind"), ("activation sequences", "doc"), ("(private: detector only)", "doc"),
                         ("bool · ipc", "tail")]
    frames = stream(g, edge(g, "adc.frames -> gate.frames"))
    assert frames.lines == ["adc_frame", "int16|float32|complex64", "ipc"]
    assert all(len(line) <= LABEL_CHARS for s in map(lambda e: stream(g, e), g.edges) for line in s.lines)
    assert stream(g, edge(g, "gate.alarms -> summary.alarms")).dtypes == "header only"


def test_a_port_of_any_kind_takes_the_kind_of_the_port_at_the_other_end(tmp_path):
    (tmp_path / "my_blocks").mkdir()
    (tmp_path / "my_blocks" / "tee.py").write_text(
        'from carav_stream.runtime import Block, In, Out\n\n\nclass Tee(Block):\n    inputs = (In("inp"),)\n'
        '    outputs = (Out("out"),)\n')
    (tmp_path / "g.toml").write_text(f'include = "{DEMO}"\nblock_paths = ["my_blocks"]\n'
                                     'remove_connections = ["channel.rx -> adc.rx"]\n'
                                     'connections = ["channel.rx -> tee.inp", "tee.out -> adc.rx"]\n'
                                     '[blocks]\ntee = { type = "tee" }\n')
    g = load_graph(tmp_path / "g.toml")
    s = stream(g, edge(g, "tee.out -> adc.rx"))
    assert (s.kind, s.dtypes, s.doc) == ("rx", "float32|complex64", "")


def test_the_transport_is_tcp_between_hosts_and_the_data_plane_on_one():
    two = load_graph(ROOT / "graphs" / "two_hosts.toml")
    assert {str(e): stream(two, e).transport for e in two.edges}["source.rho -> detector.rho"] == "tcp"
    assert stream(two, edge(two, "source.tx -> channel.tx")).transport == "ipc"
    shm = load_graph(DEMO, ["run.transport=shm"])
    assert {stream(shm, e).transport for e in shm.edges} == {"shm"}
    # an output port with an edge to another host keeps its frames inline on its other edges too (plan_plane)
    two_shm = load_graph(ROOT / "graphs" / "two_hosts.toml", ["run.transport=shm"])
    assert stream(two_shm, edge(two_shm, "source.tx -> channel.tx")).transport == "shm"
    assert {stream(two_shm, e).transport for e in two_shm.edges if e.src == "adc"} <= {"tcp", "ipc"}
