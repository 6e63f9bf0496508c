"""The picture's layout (graphview/layout.py): every arrow runs from an earlier layer to a later one, left to right;
no two boxes or labels overlap; no arrow crosses a box on its way; the demo's arrows do not cross each other; and
all of it for random acyclic graphs too."""
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carav_stream.graphview.layout import Layout, layers_of, layout
from carav_stream.runtime.loader import load_graph

ROOT = Path(__file__).resolve().parents[2]
TOYS = ROOT / "tests" / "toy_blocks"
GRAPHS = sorted((ROOT / "graphs").glob("*.toml"))


def toy_graph(tmp_path: Path, body: str):
    path = tmp_path / "g.toml"
    path.write_text(f'block_paths = ["{TOYS}"]\n{body}')
    return load_graph(path)


def rectangles(lay: Layout) -> list[tuple[str, float, float, float, float]]:
    """(what, left, top, right, bottom) of every box and every label."""
    out = [(f"box {b.node.name}", b.x, b.y, b.x + b.width, b.y + b.height) for b in lay.boxes.values()]
    out += [(f"label {r.stream.edge}", r.label_x - r.label_width / 2, r.label_y - r.label_height,
             r.label_x + r.label_width / 2, r.label_y) for r in lay.routes]
    return out


def overlaps(lay: Layout) -> list[str]:
    rects = rectangles(lay)
    return [f"{a[0]} / {b[0]}" for k, a in enumerate(rects) for b in rects[k + 1:]
            if a[1] < b[3] and b[1] < a[3] and a[2] < b[4] and b[2] < a[4]]


def arrows_through_boxes(lay: Layout) -> list[str]:
    """Arrows whose straight run across a column (between points 2k+1 and 2k+2) passes through a box."""
    found = []
    for r in lay.routes:
        for (x0, y), (x1, _) in zip(r.points[1:-1:2], r.points[2:-1:2]):
            found += [f"{r.stream.edge} through {b.node.name}" for b in lay.boxes.values()
                      if b.y < y < b.y + b.height and b.x < x1 and x0 < b.x + b.width]
    return found


def backwards(lay: Layout) -> list[str]:
    """Arrows that do not start at their output port, end at their input port, and run left to right."""
    bad = []
    for r in lay.routes:
        e, src, dst = r.stream.edge, lay.boxes[r.stream.edge.src], lay.boxes[r.stream.edge.dst]
        xs = [x for x, _ in r.points]
        if not src.layer < dst.layer or xs != sorted(xs) or xs[0] >= xs[-1]:
            bad.append(f"{e}: layers {src.layer} -> {dst.layer}, x {xs}")
        if r.points[0] != (src.x + src.width, src.out_ports[e.src_port]) or \
                r.points[-1] != (dst.x, dst.in_ports[e.dst_port]):
            bad.append(f"{e}: does not join its ports")
    return bad


def check(lay: Layout) -> None:
    assert backwards(lay) == []
    assert overlaps(lay) == []
    assert arrows_through_boxes(lay) == []
    assert all(0 <= x0 and x1 <= lay.width and 0 <= y0 and y1 <= lay.height for _, x0, y0, x1, y1 in rectangles(lay))


@pytest.mark.parametrize("path", GRAPHS, ids=lambda p: p.name)
def test_every_graph_file_is_laid_out_left_to_right_without_overlaps(path):
    lay = layout(load_graph(path, open_ok=True))
    check(lay)
    assert sorted(n for names in lay.layers for n in names) == sorted(lay.boxes)


def test_the_checks_see_an_overlap_a_backward_arrow_and_an_arrow_through_a_box():
    lay = layout(load_graph(ROOT / "graphs" / "demo.toml"))
    gate, ranging = lay.boxes["gate"], lay.boxes["ranging"]
    ranging.x, ranging.y = gate.x + 5, gate.y + 5
    assert overlaps(lay) and any("gate" in o and "ranging" in o for o in overlaps(lay))
    route = next(r for r in lay.routes if str(r.stream.edge) == "source.rho -> detector.rho")
    route.points[7] = (route.points[7][0], lay.boxes["attacker"].y + 10)     # the run across column 4
    assert arrows_through_boxes(lay) == ["source.rho -> detector.rho through attacker"]
    lay.boxes["summary"].layer = 0
    assert any(b.startswith("ranging.estimates -> summary.estimates") for b in backwards(lay))


def test_the_demo_chain_takes_one_layer_per_stage_and_its_arrows_do_not_cross():
    g = load_graph(ROOT / "graphs" / "demo.toml")
    assert layers_of(g) == {"source": 0, "channel": 1, "attacker": 2, "adc": 3, "detector": 4, "gate": 5,
                            "ranging": 6, "summary": 7}
    lay = layout(g)
    # between two columns an arrow is an S-curve with level ends: two of them cross where their order flips
    gaps: dict[float, list[tuple[float, float]]] = {}
    for r in lay.routes:
        for (x0, y0), (_, y1) in zip(r.points[0::2], r.points[1::2]):
            gaps.setdefault(round(x0), []).append((y0, y1))
    crossing = [(x, a, b) for x, ends in gaps.items() for k, a in enumerate(ends) for b in ends[k + 1:]
                if (a[0] - b[0]) * (a[1] - b[1]) < 0]
    assert crossing == []


def test_a_source_sits_just_before_its_first_consumer_and_a_node_after_its_furthest_producer(tmp_path):
    g = toy_graph(tmp_path, '''connections = ["a.out -> t1.inp", "t1.out -> t2.inp", "t2.out -> add.a",
                                              "b.out -> add.b", "a.out -> t3.inp"]
[blocks]
a = { type = "counter_source" }
b = { type = "counter_source" }
t1 = { type = "tagger" }
t2 = { type = "tagger" }
t3 = { type = "tagger" }
add = { type = "adder" }
''')
    assert layers_of(g) == {"a": 0, "t1": 1, "t2": 2, "add": 3, "b": 2, "t3": 1}
    check(layout(g))


def test_a_straight_chain_is_drawn_with_level_arrows(tmp_path):
    g = toy_graph(tmp_path, '''connections = ["a.out -> t1.inp", "t1.out -> t2.inp", "t2.out -> t3.inp"]
[blocks]
a = { type = "counter_source" }
t1 = { type = "tagger" }
t2 = { type = "tagger" }
t3 = { type = "tagger" }
''')
    for r in layout(g).routes:
        assert len({round(y, 6) for _, y in r.points}) == 1, r.points


@st.composite
def dags(draw):
    """A random acyclic graph of toy blocks: sources, one-input taggers, two-input adders, a tap."""
    n_sources = draw(st.integers(1, 3))
    names = [f"s{k}" for k in range(n_sources)]
    blocks, wires = [f's{k} = {{ type = "counter_source" }}' for k in range(n_sources)], []
    for k in range(draw(st.integers(1, 9))):
        kind = draw(st.sampled_from(["tagger", "adder", "slow_tap"]))
        name = f"tap{k}" if kind == "slow_tap" else f"n{k}"     # a tap has no output
        for port in {"tagger": ["inp"], "adder": ["a", "b"], "slow_tap": ["inp"]}[kind]:
            wires.append(f'"{draw(st.sampled_from(names))}.out -> {name}.{port}"')
        blocks.append(f'{name} = {{ type = "{kind}" }}')
        if kind != "slow_tap":
            names.append(name)
    return f"connections = [{', '.join(wires)}]\n[blocks]\n" + "\n".join(blocks) + "\n"


@given(dags())
def test_any_acyclic_graph_is_laid_out_left_to_right_without_overlaps(tmp_path_factory, body):
    check(layout(toy_graph(tmp_path_factory.mktemp("g"), body)))
