"""Block files of the transport benchmark (loaded through a graph's block_paths; `_`-files are helpers)."""
