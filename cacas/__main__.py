import sys

from cacas.cli import main

sys.exit(main())
