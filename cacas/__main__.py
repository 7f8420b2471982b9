import sys

from cacas.cli import main

if __name__ == "__main__":  # guarded: simulated studies spawn worker processes that import __main__
    sys.exit(main())
