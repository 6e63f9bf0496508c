import sys

from carav_stream.cli import entry

sys.exit(entry())
