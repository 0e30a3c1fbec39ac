"""``python -m vcavity.cli ...`` is the same as the ``vcavity`` console script."""

from vcavity.cli import console_main

console_main()
