"""``python -m mjbench`` — the same as the ``mjbench`` command."""
import sys

from .cli import main

sys.exit(main())
