"""python -m kiji ...: the same as the `kiji` command."""
import sys

from kiji.cli import main

sys.exit(main())
