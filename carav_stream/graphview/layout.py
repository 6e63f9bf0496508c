"""Where each box and arrow of a graph's picture goes: a pure function of a validated graph, in points (1/72 inch),
y growing downwards, left to right as data flows.

A layered (Sugiyama) drawing:
  1. layers: a node sits one layer right of its furthest producer (a source just left of its first consumer), so
     every connection points right (validation has refused cycles);
  2. columns: layer L is column 2L; a connection from layer L puts its label in column 2L+1 and passes the columns
     up to its consumer as a point of its own, so no arrow crosses a box or a label;
  3. order: the items of each column are sorted by the mean position of their neighbours in the column before
     (then after), port by port, keeping the order with the fewest crossings;
  4. heights: each column in turn is put as near as its order allows to where its neighbours' ports are (a least
     squares fit under the order, solved by pool-adjacent-violators), so that arrows run straight where they can.
Boxes and labels of one column are stacked with a gap and columns stand apart, so no two boxes or labels overlap.
Text sizes are estimated from character counts in the monospace font the drawing uses (CHAR_EM)."""
from __future__ import annotations

import textwrap
from dataclasses import dataclass, field

from carav_stream.graphview.describe import NodeText, Stream, graph_line, node_text, stream
from carav_stream.runtime.graph import Graph

CHAR_EM = 0.61          # advance of a character of DejaVu Sans Mono (the drawing's font), in ems
LINE_EM = 1.3           # line height, in ems
TITLE_PT, TYPE_PT, SMALL_PT, LABEL_PT, HEAD_PT = 9.5, 7.5, 7.0, 6.5, 10.0
PAD = 6.0               # inside a box, around its texts
ROW = 12.0              # height of a port's row
COL_GAP = 28.0          # between columns, where the arrows bend
ITEM_GAP = 12.0         # between boxes and labels of one column
MARGIN = 14.0
MIN_WIDTH = 360.0       # a picture of a few nodes still has room for its title
LEGEND = ("arrows: output port -> input port, labelled with the stream's kind, description, dtypes · transport; "
          "dashed: a tap")
PASSES = 12             # ordering sweeps (each down and up) and height passes


def text_w(text: str, size: float) -> float:
    return len(text) * CHAR_EM * size


def line_h(size: float) -> float:
    return LINE_EM * size


@dataclass
class Box:
    """A node's box: top-left corner, size, and the height of each port's attachment point."""

    node: NodeText
    layer: int
    x: float = 0.0
    y: float = 0.0
    width: float = 0.0
    height: float = 0.0
    in_ports: dict[str, float] = field(default_factory=dict)
    out_ports: dict[str, float] = field(default_factory=dict)
    lines: list[tuple[str, float]] = field(default_factory=list)   # header lines (text, size in points)


@dataclass
class Route:
    """A connection's arrow: from its output port through the points where it crosses columns (in pairs, where it
    enters and leaves a column) to its input port; its label's lines sit above the point (label_x, label_y)."""

    stream: Stream
    points: list[tuple[float, float]]
    label_x: float
    label_y: float
    label_width: float
    label_height: float


@dataclass
class Layout:
    title: list[str]            # the file and its description, wrapped to the picture's width
    summary: str                # graph-wide parameters, counts of nodes and connections
    subtitle: list[str]         # the summary and the legend, wrapped likewise
    boxes: dict[str, Box]
    routes: list[Route]
    layers: list[list[str]]     # node names by layer, top to bottom
    width: float
    height: float


@dataclass
class _Item:
    """A box, a label or a pass-through point in a column; `ports` maps an attachment key to (y offset, order
    fraction within the item)."""

    col: int
    width: float
    height: float
    ports: dict[object, tuple[float, float]]
    top: float = 0.0


def layers_of(graph: Graph) -> dict[str, int]:
    """Each node's layer: one right of its furthest producer; a source one left of its nearest consumer."""
    layer: dict[str, int] = {}
    order = graph.topological_order()
    for n in order:
        layer[n] = max((layer[e.src] + 1 for e in graph.edges_into(n)), default=0)
    for n in order:
        if not graph.edges_into(n) and graph.edges_from(n):
            layer[n] = min(layer[e.dst] for e in graph.edges_from(n)) - 1
    return layer


def layout(graph: Graph) -> Layout:
    """The picture's geometry (module docstring)."""
    layer = layers_of(graph)
    boxes = {n: _box(node_text(graph, n), layer[n]) for n in graph.nodes}
    streams = [stream(graph, e) for e in graph.edges]
    items, chains = _items(boxes, streams)
    n_cols = 2 * max(layer.values(), default=0) + 1
    columns = [[i for i, it in enumerate(items) if it.col == c] for c in range(n_cols)]
    segments = [(a, ka, b, kb) for chain in chains for (a, ka), (b, kb) in zip(chain, chain[1:])]
    columns = _order(columns, items, segments)
    _heights(columns, items, segments)
    lefts, widths = _columns(columns, items)
    names = list(boxes)
    for i, n in enumerate(names):
        it = items[i]
        b = boxes[n]
        b.x, b.y = lefts[it.col] + (widths[it.col] - b.width) / 2, it.top
        b.in_ports = {k[1]: it.top + v[0] for k, v in it.ports.items() if k[0] == "in"}
        b.out_ports = {k[1]: it.top + v[0] for k, v in it.ports.items() if k[0] == "out"}
    routes = [_route(s, chain, items, boxes, names, lefts, widths) for s, chain in zip(streams, chains)]
    width = max(lefts[-1] + widths[-1] + MARGIN, MIN_WIDTH)
    head = textwrap.wrap(f"{graph.path.name}: {graph.description}" if graph.description else graph.path.name,
                         int((width - 2 * MARGIN) / (CHAR_EM * HEAD_PT)))
    summary = f"{graph_line(graph) + ' · ' if graph.params else ''}{len(graph.nodes)} nodes, {len(graph.edges)} " \
        "connections"
    subtitle = textwrap.wrap(f"{summary} · {LEGEND}", int((width - 2 * MARGIN) / (CHAR_EM * SMALL_PT)))
    shift = MARGIN + len(head) * line_h(HEAD_PT) + (len(subtitle) + 1) * line_h(SMALL_PT)
    _shift(boxes, routes, shift)
    bottom = max([b.y + b.height for b in boxes.values()] + [r.label_y + 4 for r in routes], default=shift)
    by_layer = [sorted((n for n in names if layer[n] == L), key=lambda n: boxes[n].y)
                for L in range(max(layer.values(), default=0) + 1)]
    return Layout(head, summary, subtitle, boxes, routes, by_layer, width, bottom + MARGIN)


def _box(node: NodeText, layer: int) -> Box:
    """A box sized for its texts: name, type (and host), parameters, then the port rows."""
    kind = f"{node.type} @ {node.host}" if node.host else node.type
    lines = [(node.name, TITLE_PT), (kind, TYPE_PT), *((p, SMALL_PT) for p in node.params)]
    head = PAD + sum(line_h(s) for _, s in lines)
    rows = max(len(node.inputs), len(node.outputs), 1)
    port_w = max((text_w(p, SMALL_PT) for p in node.inputs), default=0) + \
        max((text_w(p, SMALL_PT) for p in node.outputs), default=0)
    width = max(max(text_w(t, s) for t, s in lines) + 2 * PAD, port_w + 3 * PAD + 12)
    return Box(node, layer, width=width, height=head + PAD + rows * ROW, lines=lines)


def _items(boxes: dict[str, Box], streams: list[Stream]) -> tuple[list[_Item], list[list[tuple[int, object]]]]:
    """The boxes (first, in the graph's order), then per connection its label and pass-through points; and per
    connection its chain of (item, attachment key) from output port to input port."""
    items, index = [], {}
    for n, b in boxes.items():
        index[n] = len(items)
        head = b.height - PAD - max(len(b.node.inputs), len(b.node.outputs), 1) * ROW
        ports = {}
        for side, names in (("in", b.node.inputs), ("out", b.node.outputs)):
            span = (b.height - PAD - head) / max(len(names), 1)
            for k, p in enumerate(names):
                ports[(side, p)] = (head + (k + 0.5) * span, (k + 1) / (len(names) + 1))
        items.append(_Item(2 * b.layer, b.width, b.height, ports))
    chains = []
    for s in streams:
        src, dst = boxes[s.edge.src], boxes[s.edge.dst]
        chain = [(index[s.edge.src], ("out", s.edge.src_port))]
        text_h = len(s.lines) * line_h(LABEL_PT)
        items.append(_Item(2 * src.layer + 1, max(text_w(t, LABEL_PT) for t in s.lines), text_h + 4,
                           {None: (text_h + 2, 0.5)}))
        chain.append((len(items) - 1, None))
        for col in range(2 * src.layer + 2, 2 * dst.layer):
            items.append(_Item(col, 0.0, 8.0, {None: (4.0, 0.5)}))
            chain.append((len(items) - 1, None))
        chain.append((index[s.edge.dst], ("in", s.edge.dst_port)))
        chains.append(chain)
    return items, chains


def _crossings(columns: list[list[int]], items: list[_Item], segments: list) -> int:
    pos = {i: k for col in columns for k, i in enumerate(col)}
    by_col: dict[int, list[tuple[float, float]]] = {}
    for a, ka, b, kb in segments:
        by_col.setdefault(items[a].col, []).append((pos[a] + items[a].ports[ka][1], pos[b] + items[b].ports[kb][1]))
    n = 0
    for segs in by_col.values():
        n += sum((u1 - u2) * (v1 - v2) < 0 for k, (u1, v1) in enumerate(segs) for u2, v2 in segs[k + 1:])
    return n


def _order(columns: list[list[int]], items: list[_Item], segments: list) -> list[list[int]]:
    """Barycentre sweeps down and up the columns; the order with the fewest crossings."""
    best, best_n = [list(c) for c in columns], _crossings(columns, items, segments)
    cols = [list(c) for c in columns]
    for sweep in range(2 * PASSES):
        forward = sweep % 2 == 0
        for c in (range(1, len(cols)) if forward else range(len(cols) - 2, -1, -1)):
            pos = {i: k for k, i in enumerate(cols[c - 1 if forward else c + 1])}
            sums: dict[int, list[float]] = {}
            for a, ka, b, kb in segments:
                mine, other = ((b, kb), (a, ka)) if forward else ((a, ka), (b, kb))
                if other[0] in pos and items[mine[0]].col == c:
                    sums.setdefault(mine[0], []).append(pos[other[0]] + items[other[0]].ports[other[1]][1])
            here = {i: k for k, i in enumerate(cols[c])}
            cols[c].sort(key=lambda i: (sum(sums[i]) / len(sums[i]) if i in sums else here[i] + 0.5, here[i]))
        n = _crossings(cols, items, segments)
        if n < best_n:
            best, best_n = [list(c) for c in cols], n
    return best


def _heights(columns: list[list[int]], items: list[_Item], segments: list) -> None:
    """Tops of the items: stacked, then each column fitted to its neighbours' ports, left to right and back."""
    for col in columns:
        top = 0.0
        for i in col:
            items[i].top = top
            top += items[i].height + ITEM_GAP
    links: dict[int, list[tuple[object, int, object]]] = {}
    for a, ka, b, kb in segments:
        links.setdefault(a, []).append((ka, b, kb))
        links.setdefault(b, []).append((kb, a, ka))
    for sweep in range(2 * PASSES + 1):
        side = (1, -1)[sweep % 2] if sweep < 2 * PASSES else 0     # the last pass looks both ways
        for c in (range(len(columns)) if side >= 0 else range(len(columns) - 1, -1, -1)):
            want, weight = [], []
            for i in columns[c]:
                ys = [items[j].top + items[j].ports[kj][0] - items[i].ports[ki][0] for ki, j, kj in links.get(i, ())
                      if side == 0 or items[j].col == c - side]
                want.append(sum(ys) / len(ys) if ys else items[i].top)
                weight.append(len(ys) or 0.01)
            for i, top in zip(columns[c], _fit(want, weight, [items[i].height + ITEM_GAP for i in columns[c]])):
                items[i].top = top
    low = min((it.top for it in items), default=0.0)
    for it in items:
        it.top -= low


def _fit(want: list[float], weight: list[float], steps: list[float]) -> list[float]:
    """Tops t minimising sum w (t - want)^2 with t[k+1] >= t[k] + steps[k]: with z = t - (sum of the steps
    before), a weighted isotonic regression of z, solved by pool-adjacent-violators."""
    offset, acc = [], 0.0
    for s in steps:
        offset.append(acc)
        acc += s
    blocks: list[list[float]] = []          # [mean, weight, count]
    for w_k, z in zip(weight, (w - o for w, o in zip(want, offset))):
        blocks.append([z, w_k, 1])
        while len(blocks) > 1 and blocks[-2][0] > blocks[-1][0]:
            m2, w2, n2 = blocks.pop()
            m1, w1, n1 = blocks.pop()
            blocks.append([(m1 * w1 + m2 * w2) / (w1 + w2), w1 + w2, n1 + n2])
    z_fit = [m for m, _, n in blocks for _ in range(n)]
    return [z + o for z, o in zip(z_fit, offset)]


def _columns(columns: list[list[int]], items: list[_Item]) -> tuple[list[float], list[float]]:
    widths = [max([items[i].width for i in col] + [8.0]) for col in columns]
    lefts, x = [], MARGIN
    for w in widths:
        lefts.append(x)
        x += w + COL_GAP
    return lefts, widths


def _route(s: Stream, chain: list, items: list[_Item], boxes: dict[str, Box], names: list[str],
           lefts: list[float], widths: list[float]) -> Route:
    src, dst = boxes[s.edge.src], boxes[s.edge.dst]
    points = [(src.x + src.width, src.out_ports[s.edge.src_port])]
    for i, key in chain[1:-1]:
        it = items[i]
        y = it.top + it.ports[key][0]
        points += [(lefts[it.col], y), (lefts[it.col] + widths[it.col], y)]
    points.append((dst.x, dst.in_ports[s.edge.dst_port]))
    label = items[chain[1][0]]
    return Route(s, points, lefts[label.col] + widths[label.col] / 2, points[1][1] - 2, label.width,
                 label.height - 4)


def _shift(boxes: dict[str, Box], routes: list[Route], dy: float) -> None:
    for b in boxes.values():
        b.y += dy
        b.in_ports = {k: v + dy for k, v in b.in_ports.items()}
        b.out_ports = {k: v + dy for k, v in b.out_ports.items()}
    for r in routes:
        r.points = [(x, y + dy) for x, y in r.points]
        r.label_y += dy
