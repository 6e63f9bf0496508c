"""A graph's picture drawn with matplotlib from its layout (layout.py): one box per node (name, block type, the
parameters the graph sets; input ports on the left, output ports on the right), one arrow per connection from
output port to input port, coloured by stream kind, dashed for a tap, labelled with its stream.

The axes are the layout's points (1/72 inch, y downwards) and the figure is exactly the layout's size, so the text
sizes the layout estimated are the ones drawn. Texts stay texts in an SVG (svg.fonttype "none"), so a reader can
search them and a test can find them; every box and arrow carries an id (`node:NAME`, `edge:SRC.PORT:DST.PORT`).
The SVG carries no date and its ids are drawn from a fixed salt, so the same graph gives the same file."""
from __future__ import annotations

from pathlib import Path

import matplotlib
from matplotlib.figure import Figure
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch
from matplotlib.path import Path as MplPath

from carav_stream.graphview import FORMATS
from carav_stream.graphview.layout import HEAD_PT, LABEL_PT, MARGIN, PAD, SMALL_PT, Box, Layout, Route, line_h

FONT = ["DejaVu Sans Mono", "monospace"]   # shipped with matplotlib; an SVG viewer without it takes a monospace
PNG_DPI = 150
MARKER_PT = 4.5                 # a port's square
# texts stay texts in an SVG; no hinting, so a character is 0.602 em wide at every dpi, as the layout assumes
STYLE = {"svg.fonttype": "none", "svg.hashsalt": "carav-graph", "font.family": FONT, "text.hinting": "no_hinting"}


def draw(lay: Layout) -> Figure:
    """The matplotlib Figure of `lay` (save() writes it with STYLE)."""
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(lay.width / 72, lay.height / 72))
        ax = fig.add_axes((0, 0, 1, 1))
        ax.set_xlim(0, lay.width)
        ax.set_ylim(lay.height, 0)
        ax.axis("off")
        colors = _colors(lay)
        y = MARGIN
        for line in lay.title:
            ax.text(MARGIN, y, line, fontsize=HEAD_PT, fontweight="bold", va="top", family=FONT)
            y += line_h(HEAD_PT)
        for line in lay.subtitle:
            ax.text(MARGIN, y + 2, line, fontsize=SMALL_PT, va="top", color="0.35", family=FONT)
            y += line_h(SMALL_PT)
        for r in lay.routes:
            _arrow(ax, r, colors[r.stream.kind])
        kinds = {}        # (node, "in" | "out", port) -> the kind of the stream its connections carry
        for r in lay.routes:
            e = r.stream.edge
            kinds[(e.src, "out", e.src_port)] = kinds[(e.dst, "in", e.dst_port)] = r.stream.kind
        for b in lay.boxes.values():
            _box(ax, b, kinds, colors)
    return fig


def save(lay: Layout, path: Path) -> None:
    """Draw `lay` into `path`, in the format its suffix names (FORMATS); ValueError for another suffix."""
    fmt = path.suffix[1:].lower()
    if fmt not in FORMATS:
        raise ValueError(f"{path}: the picture's format is named by its suffix, one of {', '.join(FORMATS)}")
    fig = draw(lay)
    with matplotlib.rc_context(STYLE):
        fig.savefig(path, format=fmt, dpi=PNG_DPI, metadata=_metadata(fmt))


def _metadata(fmt: str) -> dict:
    """No creation date, so that drawing the same graph twice writes the same file."""
    return {"svg": {"Date": None}, "pdf": {"CreationDate": None}, "png": {}}.get(fmt, {})


def _colors(lay: Layout) -> dict[str, tuple]:
    kinds = sorted({r.stream.kind for r in lay.routes})
    cmap = matplotlib.colormaps["tab10"]
    return {k: cmap(i % 10) for i, k in enumerate(kinds)}


def _path(points: list[tuple[float, float]]) -> MplPath:
    """Straight across each column, a cubic S-curve with level ends between columns."""
    verts, codes = [points[0]], [MplPath.MOVETO]
    for k, ((x0, y0), (x1, y1)) in enumerate(zip(points, points[1:])):
        if k % 2 == 1:          # inside a column: straight
            verts.append((x1, y1))
            codes.append(MplPath.LINETO)
            continue
        dx = (x1 - x0) / 2
        verts += [(x0 + dx, y0), (x1 - dx, y1), (x1, y1)]
        codes += [MplPath.CURVE4] * 3
    return MplPath(verts, codes)


def _arrow(ax, r: Route, color) -> None:
    e = r.stream.edge
    (x, y), *_ = r.points[-1:]
    points = [*r.points[:-1], (x - MARKER_PT / 2, y)]      # the head touches the port's marker, not hidden by it
    arrow = FancyArrowPatch(path=_path(points), arrowstyle="-|>", mutation_scale=9, color=color, linewidth=1.1,
                            linestyle=(0, (4, 2.5)) if r.stream.tap else "-", shrinkA=0, shrinkB=0, zorder=2)
    arrow.set_gid(f"edge:{e.src}.{e.src_port}:{e.dst}.{e.dst_port}")
    ax.add_patch(arrow)
    y = r.label_y
    for text, role in reversed(r.stream.label):     # bottom line first, just above the arrow
        ax.text(r.label_x, y, text, fontsize=LABEL_PT, ha="center", va="bottom", family=FONT, zorder=3,
                color=color if role == "kind" else "0.25", fontweight="bold" if role == "kind" else "normal",
                fontstyle="italic" if role == "doc" else "normal")
        y -= line_h(LABEL_PT)


def _box(ax, b: Box, kinds: dict[tuple[str, str, str], str], colors: dict[str, tuple]) -> None:
    patch = FancyBboxPatch((b.x, b.y), b.width, b.height, boxstyle="round,pad=0,rounding_size=4",
                           facecolor="#eef3fa", edgecolor="#34495e", linewidth=1.0, zorder=4)
    patch.set_gid(f"node:{b.node.name}")
    ax.add_patch(patch)
    y = b.y + PAD / 2
    for k, (text, size) in enumerate(b.lines):
        ax.text(b.x + b.width / 2, y, text, fontsize=size, ha="center", va="top", family=FONT, zorder=5,
                fontweight="bold" if k == 0 else "normal", color="black" if k < 2 else "0.3")
        y += line_h(size)
    for side, ports, x, ha, dx in (("in", b.in_ports, b.x, "left", 5.0),
                                   ("out", b.out_ports, b.x + b.width, "right", -5.0)):
        for name, py in ports.items():
            kind = kinds.get((b.node.name, side, name))      # None: declared, not connected (drawn hollow)
            ax.plot([x], [py], marker="s", markersize=MARKER_PT, zorder=6, markeredgecolor="#34495e",
                    markeredgewidth=0.6, color="white" if kind is None else colors[kind])
            ax.text(x + dx, py, name, fontsize=SMALL_PT, ha=ha, va="center", family=FONT, zorder=5,
                    color="0.55" if kind is None else "black")
