"""Composition that splices: an including graph removes included connections and inserts a block into the chain;
a node given another variant (the attacker's model) starts from that variant's defaults; validation names both."""
import pytest

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.runtime.graph import GraphError
from carav_stream.runtime.loader import load_graph
from tests.cli.test_one_line_refusals import DEMO


def own(g, node):
    """A node's parameters less the graph-wide ones (scene, seed) every radar block takes."""
    return {k: v for k, v in g.nodes[node].params.items() if k not in g.params}

PASSTHROUGH = '''from carav_stream.runtime import Block, Frame, In, Out


class Tee(Block):
    inputs = (In("inp"),)
    outputs = (Out("out"),)

    def process(self, inp: Frame) -> Frame:
        return inp.derive(keep_data=True)
'''
SPLICED = f'''include = "{DEMO}"
block_paths = ["my_blocks"]
remove_connections = ["channel.rx -> adc.rx"]
connections = ["channel.rx -> tee.inp", "tee.out -> adc.rx"]
[blocks]
tee = {{ type = "tee" }}
'''


@pytest.fixture
def spliced(tmp_path):
    (tmp_path / "my_blocks").mkdir()
    (tmp_path / "my_blocks" / "tee.py").write_text(PASSTHROUGH)
    path = tmp_path / "spliced.toml"
    path.write_text(SPLICED)
    return path


def test_an_including_graph_inserts_a_block_between_channel_and_adc(spliced):
    g = load_graph(spliced)
    wires = {str(e) for e in g.edges}
    assert "channel.rx -> adc.rx" not in wires
    assert {"channel.rx -> tee.inp", "tee.out -> adc.rx"} <= wires and len(wires) == 12
    assert g.composed == ["removes the connection channel.rx -> adc.rx of demo.toml"]


def test_validate_names_what_the_graph_replaced(spliced, capsys):
    assert carav(["validate", str(spliced)]) == Exit.OK
    out = capsys.readouterr().out
    assert out.splitlines()[1:] == ["  removes the connection channel.rx -> adc.rx of demo.toml"], out


@pytest.mark.parametrize("removed, text", [
    ('["channel.rx -> ranging.frames"]', "remove_connections: 'channel.rx -> ranging.frames' is not a connection "
                                         "of the included graph (demo.toml)"),
    ('"channel.rx -> adc.rx"', "remove_connections: must be a list of connections"),
])
def test_removing_a_connection_the_included_graph_lacks_is_refused_naming_it(tmp_path, removed, text):
    path = tmp_path / "g.toml"
    path.write_text(f'include = "{DEMO}"\nremove_connections = {removed}\n')
    with pytest.raises(GraphError) as err:
        load_graph(path)
    assert any(text in p for p in err.value.problems), err.value.problems


def test_a_graph_that_includes_none_cannot_remove_connections(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text('remove_connections = ["a.out -> b.inp"]\n[blocks]\na = { type = "counter_source" }\n')
    with pytest.raises(GraphError) as err:
        load_graph(path)
    assert any("only a graph that includes another can remove its connections" in p for p in err.value.problems)


def test_switching_the_attacker_off_by_override_starts_from_the_none_models_defaults(capsys):
    g = load_graph(DEMO, ["attacker.model=none"])
    assert own(g, "attacker") == {"model": "none"}
    assert g.composed == ["blocks.attacker: model 'none' starts from its own defaults: rarms, start_cycle of "
                          "demo.toml not inherited"]
    assert carav(["validate", DEMO, "--set", "attacker.model=none"]) == Exit.OK


def test_an_including_graph_that_changes_the_model_keeps_only_what_it_writes(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(f'include = "{DEMO}"\n[blocks]\nattacker = {{ model = "random", rarms = 2.0 }}\n')
    g = load_graph(path)
    assert own(g, "attacker") == {"model": "random", "rarms": 2.0}       # start_cycle not inherited
    assert g.composed == ["blocks.attacker: model 'random' starts from its own defaults: start_cycle of demo.toml, "
                          "radar_chain.toml not inherited"]


def test_an_including_graph_that_keeps_the_model_inherits_the_rest(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(f'include = "{DEMO}"\n[blocks]\nattacker = {{ model = "smart", rarms = 5.0 }}\n')
    g = load_graph(path)
    assert own(g, "attacker") == {"model": "smart", "rarms": 5.0, "start_cycle": 150} and g.composed == []


@pytest.mark.integration
def test_the_test_kit_splices_a_block_into_the_chain_and_the_graph_runs_with_it(carav, tmp_path):
    from carav_stream.testing.radar import check_fail_closed, radar_graph

    (tmp_path / "my_blocks").mkdir()
    (tmp_path / "my_blocks" / "tee.py").write_text(PASSTHROUGH)
    path = radar_graph(carav, {"tee": {"type": "tee"}, "attacker": {"model": "none"}},
                       block_paths=[tmp_path / "my_blocks"], base=DEMO, remove_connections=["channel.rx -> adc.rx"],
                       connections=["channel.rx -> tee.inp", "tee.out -> adc.rx"])
    run = carav.run(path, "--cycles", "64")
    assert run.wait() == 0, run.stderr()
    summary = run.summary()
    assert summary["lost"] == 0 and summary["attacked_cycles"] == 0
    tee = summary["per_node"]["tee"]
    assert sum(tee["in"].values()) == sum(tee["out"].values()) == sum(summary["per_node"]["adc"]["out"].values())
    assert check_fail_closed(carav.workdir)[1] == 64


def test_an_attacker_left_unconnected_is_warned_about(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(f'include = "{DEMO}"\nremove_connections = ["attacker.attack -> adc.attack"]\n')
    g = load_graph(path)
    assert g.warnings == ["blocks.attacker (attacker): none of its outputs (attack) is connected: it runs, and "
                          "nothing takes what it computes"]
    assert load_graph(DEMO).warnings == []


def test_an_input_connected_twice_points_at_remove_connections(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(f'include = "{DEMO}"\nconnections = ["channel.rx -> adc.rx"]\n')
    with pytest.raises(GraphError) as err:
        load_graph(path)
    assert any("adc.rx is connected twice" in p and "remove_connections" in p for p in err.value.problems)
