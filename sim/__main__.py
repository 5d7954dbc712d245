"""``python -m sim`` is the ``nhsim`` command."""

from sim.cli import main

raise SystemExit(main())
