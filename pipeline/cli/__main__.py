"""``python -m microslip.cli``: the command, as the installed ``microslip``."""

from microslip.cli import main

raise SystemExit(main())
