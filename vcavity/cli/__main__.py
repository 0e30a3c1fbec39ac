"""``python -m vcavity.cli ...`` is the same as the ``vcavity`` console script."""

import sys

from vcavity.cli import main

sys.exit(main())
