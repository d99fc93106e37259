"""``python -m brdffit.cli``: the ``brdffit`` command."""

import sys

from .main import main

sys.exit(main())
