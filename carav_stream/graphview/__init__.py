"""Pictures of graph files: what each node and connection says (describe), where each box and arrow goes (layout,
a pure function of the graph), and the drawing of that layout with matplotlib (draw), as `carav graph` makes them."""

FORMATS = ("svg", "png", "pdf")     # what draw.save writes, named by the file's suffix
