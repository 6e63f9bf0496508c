"""`carav keys DIR`: ZeroMQ CURVE keys for a graph's tcp edges, and the [security] table that names them.

Writes, into a new or empty folder DIR made private (mode 0700; secret-key files 0600):

    DIR/server.key, DIR/server.key_secret    the key pair of every tcp input (the CURVE servers)
    DIR/client.key, DIR/client.key_secret    the key pair of every tcp output (the CURVE clients)
    DIR/authorized/client.key                the client keys the inputs admit

and prints the [security] table to add to the graph file. Copy DIR to every host of the graph, privately: its
secret keys let a process send into the graph's tcp edges and read them. A graph whose hosts are all this machine
needs none of this: `carav run` makes keys for the run (docs/RUNTIME.md).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from carav_stream.console.errors import Exit, fail
from carav_stream.console.options import output_folder
from carav_stream.runtime.curve import write_keys


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("folder", type=output_folder, metavar="DIR", help="a new or empty folder for the keys")


def run(args: argparse.Namespace) -> int:
    folder: Path = args.folder
    if folder.exists() and any(folder.iterdir()):
        return fail(f"{folder}: folder is not empty; keys are written only into a new or empty folder", Exit.USAGE)
    files = write_keys(folder.resolve())
    print("[security]")
    for key, path in files.items():
        print(f"{key} = {json.dumps(path)}")
    print(f"# copy {folder} to every host of the graph, privately: its secret keys let a process send into the "
          "graph's tcp edges and read them")
    return Exit.OK
