"""The shipped graph files, installed with the package as `carav_graphs` (like the blocks as `carav_blocks`), so
benchmarks and studies load the same files a user runs, from a checkout or from a regular install."""
from pathlib import Path

FOLDER = Path(__file__).resolve().parent


def graph_file(name: str) -> Path:
    """The path of a shipped graph: graph_file("radar_chain") -> .../radar_chain.toml."""
    path = FOLDER / f"{name}.toml"
    if not path.is_file():
        known = sorted(p.stem for p in FOLDER.glob("*.toml"))
        raise FileNotFoundError(f"no shipped graph {name!r} (shipped: {', '.join(known)})")
    return path
