"""`carav graph`: the picture names every node and connection of the graph, as texts and as ids an SVG reader can
find; an invalid graph is refused as `carav validate` refuses it; a graph that splices a block into an included
chain is drawn spliced; without --out the same as text; the picture in docs/ is the one the command draws now."""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from carav_stream import graphview
from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.runtime.loader import load_graph
from tests.runtime.test_graph_splice import PASSTHROUGH, SPLICED

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "graphs" / "demo.toml"
SVG = "{http://www.w3.org/2000/svg}"


def svg_of(path: Path) -> tuple[set[str], dict[str, ET.Element]]:
    """The texts of an SVG picture and its elements by id."""
    root = ET.parse(path).getroot()
    texts = {"".join(t.itertext()).strip() for t in root.iter(f"{SVG}text")}
    return texts, {el.get("id"): el for el in root.iter() if el.get("id")}


def draw(tmp_path: Path, graph: Path, capsys, *more: str, name: str = "g.svg") -> Path:
    out = tmp_path / name
    assert carav(["graph", str(graph), "--out", str(out), *more]) == Exit.OK
    assert capsys.readouterr().out == f"{out}\n"
    return out


@pytest.fixture(scope="module")
def demo_svg(tmp_path_factory):
    out = tmp_path_factory.mktemp("graph") / "demo.svg"
    assert carav(["graph", str(DEMO), "--out", str(out)]) == Exit.OK
    return out


def test_every_node_and_connection_of_the_demo_is_in_its_svg(demo_svg):
    g = load_graph(DEMO)
    texts, ids = svg_of(demo_svg)
    for name, node in g.nodes.items():
        assert {name, node.type} <= texts and f"node:{name}" in ids, name
    for e in g.edges:
        assert f"edge:{e.src}.{e.src_port}:{e.dst}.{e.dst_port}" in ids, e
        assert {e.src_port, e.dst_port} <= texts, e
    assert len([i for i in ids if i.startswith("edge:")]) == len(g.edges)
    assert len([i for i in ids if i.startswith("node:")]) == len(g.nodes)
    # what travels, and the attacker's model and strength
    assert {"adc_frame", "rho", "verdict", "clean_frame", "int16|float32|complex64", "bool · ipc"} <= texts
    assert {"model = smart", "rarms = 3", "start_cycle = 150 cycles", "eta = 1.5"} <= texts


def test_the_same_graph_draws_the_same_svg(demo_svg, tmp_path, capsys):
    assert draw(tmp_path, DEMO, capsys).read_bytes() == demo_svg.read_bytes()


def test_a_set_override_is_drawn(tmp_path, capsys):
    texts, _ = svg_of(draw(tmp_path, DEMO, capsys, "--set", "attacker.model=random", "--set", "attacker.rarms=2"))
    assert {"model = random", "rarms = 2"} <= texts and "model = smart" not in texts


def test_a_tap_is_dashed_and_the_shared_memory_plane_named(tmp_path, capsys):
    graph = tmp_path / "tap.toml"
    graph.write_text(f'include = "{DEMO}"\nconnections = ["gate.alarms -> view.alarms"]\n[run]\ntransport = "shm"\n'
                     '[blocks]\nview = { type = "live_view" }\n')
    texts, ids = svg_of(draw(tmp_path, graph, capsys))
    dashed = {i for i, el in ids.items() if i.startswith("edge:")
              and any("stroke-dasharray" in (p.get("style") or "") for p in el.iter(f"{SVG}path"))}
    assert dashed == {"edge:gate.alarms:view.alarms"}
    assert {"header only · shm · tap", "bool · shm"} <= texts


def test_an_edge_between_hosts_is_labelled_tcp(tmp_path, capsys):
    texts, _ = svg_of(draw(tmp_path, ROOT / "graphs" / "two_hosts.toml", capsys))
    assert {"bool · tcp", "chirp_source @ front", "rms_detector @ back"} <= texts


def test_a_spliced_graph_is_drawn_with_the_block_in_the_chain(tmp_path, capsys):
    (tmp_path / "my_blocks").mkdir()
    (tmp_path / "my_blocks" / "tee.py").write_text(PASSTHROUGH)
    (tmp_path / "spliced.toml").write_text(SPLICED)     # demo.toml, a tee between channel and adc
    texts, ids = svg_of(draw(tmp_path, tmp_path / "spliced.toml", capsys))
    edges = {i for i in ids if i.startswith("edge:")}
    assert {"edge:channel.rx:tee.inp", "edge:tee.out:adc.rx"} <= edges
    assert "edge:channel.rx:adc.rx" not in edges and len(edges) == 12
    assert {"tee", "node:tee"} <= texts | set(ids)


@pytest.mark.slow
@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".pdf", b"%PDF")])
def test_the_suffix_names_the_format(tmp_path, capsys, suffix, magic):
    assert draw(tmp_path, DEMO, capsys, name=f"g{suffix}").read_bytes().startswith(magic)


def test_an_unknown_suffix_is_refused_before_anything_is_drawn(tmp_path, capsys):
    assert carav(["graph", str(DEMO), "--out", str(tmp_path / "g.jpeg")]) == Exit.USAGE
    err = capsys.readouterr().err
    assert "--out" in err and "g.jpeg" in err and ".svg" in err, err
    assert not (tmp_path / "g.jpeg").exists()


def invalid_graph(tmp_path: Path) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(f'include = "{DEMO}"\nremove_connections = ["channel.rx -> ranging.frames"]\n'
                    '[blocks]\ndetector = { eta = -1.5 }\ngate = { type = "gaet" }\n')
    return path


@pytest.mark.parametrize("argv", [
    ["{bad}"],
    [str(DEMO), "--set", "detector.eta=-1.5"],
    [str(DEMO), "--set", "nosuch.eta=1"],
    ["{missing}"],
], ids=["three-problems", "set", "unknown-node", "missing-file"])
def test_an_invalid_graph_is_refused_with_validates_messages_and_exit_code(tmp_path, capsys, argv):
    argv = [a.format(bad=invalid_graph(tmp_path), missing=tmp_path / "none.toml") for a in argv]
    out = tmp_path / "g.svg"
    code = carav(["graph", *argv, "--out", str(out)])
    graph_err = capsys.readouterr()
    assert code == carav(["validate", *argv]) == Exit.INVALID
    assert graph_err.err == capsys.readouterr().err != ""
    assert graph_err.out == "" and not out.exists()


def test_the_three_problems_are_each_named(tmp_path, capsys):
    assert carav(["graph", str(invalid_graph(tmp_path))]) == Exit.INVALID
    err = capsys.readouterr().err
    assert "'channel.rx -> ranging.frames' is not a connection" in err
    assert "blocks.detector.eta: must be > 0, got -1.5" in err and "gaet" in err, err


def test_without_out_it_prints_the_nodes_by_layer_and_every_connection(capsys):
    assert carav(["graph", str(DEMO)]) == Exit.OK
    out = capsys.readouterr().out.splitlines()
    g = load_graph(DEMO)
    rows = [line.split() for line in out if line[:5].strip().isdigit()]
    assert [(int(r[0]), r[1], r[2]) for r in rows] == [
        (0, "source", "chirp_source"), (1, "channel", "channel"), (2, "attacker", "attacker"),
        (3, "adc", "adc_framer"), (4, "detector", "rms_detector"), (5, "gate", "gate"),
        (6, "ranging", "range_estimator"), (7, "summary", "run_summary")]
    assert any(r[1] == "attacker" and " ".join(r[3:]) == "model = smart, rarms = 3, start_cycle = 150 cycles"
               for r in rows)
    edges = [line for line in out if " -> " in line]
    assert [line.split()[0:3] for line in edges] == [str(e).split() for e in g.edges]
    assert any(line.split()[3:6] == ["rho", "bool", "·"] and line.endswith("(private: detector only)")
               for line in edges)


def test_without_matplotlib_the_text_still_works_and_a_picture_is_refused_in_one_line(tmp_path, capsys,
                                                                                        monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)       # as if matplotlib were not installed
    monkeypatch.delitem(sys.modules, "carav_stream.graphview.draw", raising=False)
    monkeypatch.delattr(graphview, "draw", raising=False)
    assert carav(["graph", str(DEMO)]) == Exit.OK
    capsys.readouterr()
    assert carav(["graph", str(DEMO), "--out", str(tmp_path / "g.svg")]) == Exit.FAILED
    err = capsys.readouterr().err
    assert "needs matplotlib" in err and "carav-stream[plot]" in err and len(err.splitlines()) == 1


def test_the_demo_picture_in_the_documents_is_the_one_the_command_draws(demo_svg):
    # docs/GRAPHS.md names the command that draws it; compared by what it says, not byte for byte (another
    # matplotlib may write the same picture differently)
    doc = ROOT / "docs" / "figures" / "demo_graph.svg"
    assert "carav graph graphs/demo.toml --out docs/figures/demo_graph.svg" in (ROOT / "docs" / "GRAPHS.md").read_text()
    texts, ids = svg_of(doc)
    now_texts, now_ids = svg_of(demo_svg)
    ours = {i for i in ids if i.startswith(("node:", "edge:"))}
    assert texts == now_texts and ours == {i for i in now_ids if i.startswith(("node:", "edge:"))} or pytest.fail(
        f"docs/figures/demo_graph.svg is stale: run the command named in docs/GRAPHS.md "
        f"(texts gone {sorted(texts - now_texts)}, new {sorted(now_texts - texts)})")
