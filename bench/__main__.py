"""`python -m bench NAME [options]` from the repository's root: what `python3 dev.py bench NAME` runs."""
import sys

from bench import main

if __name__ == "__main__":
    sys.exit(main())
