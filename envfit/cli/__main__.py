"""``python -m envfit.cli …`` is the ``envfit`` command."""
import sys

from . import main

sys.exit(main())
