"""Graph composition (`include`) and graph-wide parameters, on toy blocks and on the shipped radar graphs."""
from pathlib import Path

import pytest

from carav_stream.runtime.graph import GraphError
from carav_stream.runtime.loader import load_graph

TOYS = Path(__file__).resolve().parents[1] / "toy_blocks"
GRAPHS = Path(__file__).resolve().parents[2] / "graphs"

BASE = f"""
block_paths = ["{TOYS}"]
description = "base"
connections = ["src.out -> t.inp", "t.out -> log.inp"]
[run]
cycles = 10
queue_frames = 4
[hosts.h]
address = "127.0.0.2"
port_base = 47000
[blocks]
src = {{ type = "counter_source", n_values = 3 }}
t = {{ type = "tagger", offset = 1.0, delay_s = 0.0 }}
log = {{ type = "jsonl_sink", path = "x.jsonl" }}
"""


def write(folder: Path, name: str, body: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(body)
    return folder / name


def problems_of(path: Path, overrides=()) -> str:
    with pytest.raises(GraphError) as info:
        load_graph(path, list(overrides))
    return "\n".join(info.value.problems)


def test_an_including_graph_states_only_what_differs(tmp_path):
    write(tmp_path / "lib", "base.toml", BASE)
    g = load_graph(write(tmp_path, "top.toml", """
include = "lib/base.toml"
description = "top"
tag = "top"
connections = ["t.out -> log2.inp"]
[run]
cycles = 20
[hosts.h]
port_base = 48000
[blocks]
t = { offset = 2.5 }
log2 = { type = "jsonl_sink", path = "y.jsonl" }
"""))
    assert g.description == "top"                                           # top-level values replace
    assert g.run["cycles"] == 20 and g.run["queue_frames"] == 4             # [run] merges key by key
    assert (g.hosts["h"].address, g.hosts["h"].port_base) == ("127.0.0.2", 48000)   # tables within tables too
    assert g.nodes["t"].params["offset"] == 2.5 and g.nodes["t"].params["tag"] == "top"   # a change keeps the rest
    assert g.nodes["src"].params["n_values"] == 3
    assert [str(e) for e in g.edges] == ["src.out -> t.inp", "t.out -> log.inp", "t.out -> log2.inp"]   # appended


def test_a_node_written_with_a_type_replaces_the_included_one_entirely(tmp_path):
    write(tmp_path, "base.toml", BASE)
    g = load_graph(write(tmp_path, "top.toml", 'include = "base.toml"\n[blocks]\nt = { type = "tagger_b" }\n'))
    assert g.nodes["t"].type == "tagger_b" and "offset" not in g.nodes["t"].params


def test_a_change_to_a_node_the_included_graph_lacks_is_refused(tmp_path):
    write(tmp_path, "base.toml", BASE)
    found = problems_of(write(tmp_path, "top.toml", 'include = "base.toml"\n[blocks]\nghost = { offset = 1 }\n'))
    assert "top.toml: blocks.ghost: changes a node the included graph does not have; give it a type" in found


def test_include_cycles_missing_files_and_bad_values_are_named(tmp_path):
    write(tmp_path, "a.toml", 'include = "b.toml"\n')
    write(tmp_path, "b.toml", 'include = "a.toml"\n')
    assert "graph files include each other: a.toml -> b.toml -> a.toml" in problems_of(tmp_path / "a.toml")
    found = problems_of(write(tmp_path, "c.toml", 'include = "nowhere.toml"\n'))
    assert "nowhere.toml: graph file not found" in found
    assert "c.toml: include: 'nowhere.toml' could not be read" in found
    assert "c.toml: include: must be the name of a graph file, got 3" in problems_of(write(tmp_path, "c.toml",
                                                                                         "include = 3\n"))


def test_a_relative_block_folder_stays_relative_to_the_file_that_wrote_it(tmp_path):
    (tmp_path / "lib" / "my_blocks").mkdir(parents=True)
    (tmp_path / "lib" / "my_blocks" / "tagger_c.py").write_text((TOYS / "tagger_b.py").read_text()
                                                               .replace('"tagger_b"', '"tagger_c"'))
    write(tmp_path / "lib", "base.toml", BASE.replace('block_paths = [', 'block_paths = ["my_blocks", '))
    g = load_graph(write(tmp_path, "top.toml", 'include = "lib/base.toml"\n[blocks]\nt = { type = "tagger_c" }\n'))
    assert g.nodes["t"].type == "tagger_c"
    assert "block folder" in problems_of(write(tmp_path, "bad.toml", BASE.replace('block_paths = [',
                                                                                     'block_paths = ["nope", ')))


PLAYERS = ("replay.toml", "gnuradio.toml", "gr_radar.toml")   # graphs whose ADC frames come from outside: the chain
                                                              # after the ADC


@pytest.mark.parametrize("graph", sorted(p.name for p in GRAPHS.glob("*.toml") if p.name not in PLAYERS))
def test_every_shipped_graph_loads_and_includes_the_radar_chain_unchanged(graph):
    chain = load_graph(GRAPHS / "radar_chain.toml")
    g = load_graph(GRAPHS / graph)
    assert {str(e) for e in chain.edges} <= {str(e) for e in g.edges}      # detection stays ahead of ranging
    assert {n: node.type for n, node in chain.nodes.items()}.items() <= {n: node.type for n, node in
                                                                        g.nodes.items()}.items()
    assert g.params["scene"] in ("table1", "table1_following", "awr1642", "awr1642_mimo")


def test_the_replay_graph_asks_for_its_recording_and_keeps_detection_ahead_of_ranging():
    assert problems_of(GRAPHS / "replay.toml") == ("replay.toml: blocks.source.path: missing required parameter "
                                                  "(the recording (BASE, BASE.sigmf-meta or a folder)); the graph is "
                                                  "a template that leaves it open: give it with --set "
                                                  "source.path=VALUE")
    assert load_graph(GRAPHS / "replay.toml", open_ok=True).open_params == ["source.path"]
    chain, replay = load_graph(GRAPHS / "radar_chain.toml"), (GRAPHS / "replay.toml").read_text()
    for edge in chain.edges:   # every edge of the chain from the ADC's frames on, the player in the ADC's place
        if edge.src not in ("source", "channel", "attacker"):
            assert f'"{str(edge).replace("adc.frames", "source.frames")}"' in replay, edge
    assert '"source.rho -> detector.rho"' in replay


@pytest.mark.parametrize("graph, scene", [("gnuradio.toml", "table1"),
                                          ("gr_radar.toml", str(GRAPHS.parent / "examples" / "gnuradio" /
                                                                "gr_radar_fmcw.toml"))])
def test_the_gnu_radio_graphs_keep_the_chain_after_the_adc_with_their_source_in_the_adc_s_place(graph, scene):
    chain, g = load_graph(GRAPHS / "radar_chain.toml"), load_graph(GRAPHS / graph)
    after_adc = {str(e).replace("adc.frames", "source.frames") for e in chain.edges
                 if e.src not in ("source", "channel", "attacker")}
    assert after_adc | {"source.rho -> detector.rho"} == {str(e) for e in g.edges}
    assert g.nodes["source"].type == "gr_zmq_source" and g.params["scene"] == scene


def test_graph_wide_radar_parameters_are_checked_once_and_must_agree_across_blocks():
    demo = GRAPHS / "demo.toml"
    found = problems_of(demo, ["scene=nosuch"])
    assert found.count("no such scene file or preset") == 1                   # once, not once per block
    found = problems_of(demo, ["channel.fidelity=waveform"])
    assert "fidelity: a graph-wide parameter has one value for the whole graph" in found
    assert "channel 'waveform', attacker 'beat'" in found
    g = load_graph(demo, ["fidelity=waveform", "batch=4", "seed=3"])          # set once: every block follows
    assert {n.params["fidelity"] for n in g.nodes.values() if "fidelity" in n.params} == {"waveform"}
    assert g.nodes["source"].params["batch"] == 4 and g.params["seed"] == 3
    assert "batch: must be >= 1, got 0" in problems_of(demo, ["batch=0"])
    assert "blocks.detector.eta: must be a finite number, got nan" in problems_of(demo, ["detector.eta=nan"])


TEMPLATE = f"""
block_paths = ["{TOYS}"]
template = ["log.path"]
connections = ["src.out -> log.inp"]
[blocks]
src = {{ type = "counter_source", n_values = 3 }}
log = {{ type = "jsonl_sink" }}
"""


def test_a_template_checked_as_one_may_leave_its_listed_parameters_open_and_nothing_else(tmp_path):
    g = load_graph(write(tmp_path, "t.toml", TEMPLATE), open_ok=True)
    assert g.open_params == ["log.path"]
    assert load_graph(tmp_path / "t.toml", ["log.path=out.jsonl"], open_ok=True).open_params == []
    assert load_graph(tmp_path / "t.toml", ["log.path=out.jsonl"]).nodes["log"].params["path"] == "out.jsonl"
    # run as it stands, the open parameter is missing, and the message says how to give it
    (problem,) = problems_of(tmp_path / "t.toml").splitlines()
    assert problem.startswith("t.toml: blocks.log.path: missing required parameter (")
    assert problem.endswith("); the graph is a template that leaves it open: give it with --set log.path=VALUE")
    # a template's other problems are still problems, checked as a template or not
    with pytest.raises(GraphError) as info:
        load_graph(write(tmp_path, "t2.toml", TEMPLATE.replace("n_values = 3", "n_values = -3")), open_ok=True)
    assert info.value.problems == ["t2.toml: blocks.src.n_values: must be >= 1, got -3"]


@pytest.mark.parametrize("entry, text", [
    ('["nosuch.path"]', "t.toml: template: 'nosuch.path': expected NODE.PARAM with one of the nodes ['log', 'src']"),
    ('["log"]', "t.toml: template: 'log': expected NODE.PARAM with one of the nodes ['log', 'src']"),
    ('["log.pth"]', "t.toml: template: 'log.pth': block type 'jsonl_sink' has no parameter 'pth'"),
    ('"log.path"', "t.toml: template: must be a list of strings, got 'log.path'"),
])
def test_a_template_names_only_parameters_its_nodes_declare(tmp_path, entry, text):
    path = write(tmp_path, "t.toml", TEMPLATE.replace('["log.path"]', entry))
    with pytest.raises(GraphError) as info:
        load_graph(path, open_ok=True)
    assert text in "\n".join(info.value.problems)
