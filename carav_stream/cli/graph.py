"""`carav graph GRAPH [--set ...] [--out PICTURE.svg|.png|.pdf]`: a graph file as a picture, laid out left to right
in layers as data flows: a box per node (name, block type, the parameters the graph sets; input ports left, output
ports right), an arrow per connection labelled with its stream (kind, description, dtypes, transport), dashed for a
tap. Without --out, the same as text: the nodes by layer, then the connections.

The graph is loaded and checked as `carav validate` does (includes, remove_connections, --set, --blocks; a template
may leave its parameters open): an invalid graph is refused with validate's messages and exit code. The picture
needs matplotlib (the `plot` extra); the text does not."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import output_file
from carav_stream.graphview import FORMATS
from carav_stream.graphview.layout import Layout, layout
from carav_stream.runtime.graph import GraphError
from carav_stream.runtime.loader import load_graph


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("graph", type=Path)
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR")
    p.add_argument("--out", type=output_file, metavar="PICTURE", help="write the picture: .svg, .png or .pdf")


def run(args: argparse.Namespace) -> int:
    if args.out is not None and args.out.suffix[1:].lower() not in FORMATS:
        raise CommandError(f"--out: {args.out}: the picture's format is named by its suffix, one of "
                           f"{', '.join('.' + f for f in FORMATS)}")
    try:
        g = load_graph(args.graph, args.set, args.blocks, open_ok=True)
    except GraphError as exc:
        print("\n".join(exc.problems), file=sys.stderr)
        return Exit.INVALID
    for w in g.warnings:
        print(f"{args.graph}: warning: {w}", file=sys.stderr)
    lay = layout(g)
    if args.out is None:
        print("\n".join(text_lines(lay)))
        return Exit.OK
    try:
        # matplotlib is optional (the plot extra) and slow to import: only a picture needs it
        from carav_stream.graphview import draw
    except ImportError as exc:
        raise CommandError(f"--out needs matplotlib ({exc}): pip install 'carav-stream[plot]'", Exit.FAILED) from None
    draw.save(lay, args.out)
    print(args.out)
    return Exit.OK


def text_lines(lay: Layout) -> list[str]:
    """The picture as text: title, the nodes by layer (with the parameters the graph sets), the connections."""
    boxes = lay.boxes.values()
    name_w = max(len(b.node.name) for b in boxes)
    type_w = max(len(b.node.type) + (len(b.node.host) + 3 if b.node.host else 0) for b in boxes)
    out = [*lay.title, lay.summary, ""]
    out.append(f"layer  {'node':<{name_w}}  {'block':<{type_w}}  parameters")
    for n_layer, names in enumerate(lay.layers):
        for name in names:
            b = lay.boxes[name]
            kind = f"{b.node.type} @ {b.node.host}" if b.node.host else b.node.type
            out.append(f"{n_layer:>5}  {name:<{name_w}}  {kind:<{type_w}}  {', '.join(b.node.params)}".rstrip())
    streams = [r.stream for r in lay.routes]
    edge_w = max((len(str(s.edge)) for s in streams), default=0)
    kind_w = max((len(s.kind) for s in streams), default=0)
    tail_w = max((len(s.tail) for s in streams), default=0)
    out += ["", f"{'connection':<{edge_w}}  {'stream':<{kind_w}}  {'dtypes · transport':<{tail_w}}  description"]
    for s in streams:
        out.append(f"{str(s.edge):<{edge_w}}  {s.kind:<{kind_w}}  {s.tail:<{tail_w}}  {s.doc}".rstrip())
    return out
