"""``python -m sim`` is the ``nhsim`` command."""

from sim.cli.main import main

raise SystemExit(main())
