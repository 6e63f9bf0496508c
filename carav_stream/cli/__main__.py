import sys

from carav_stream.cli import main

sys.exit(main())
