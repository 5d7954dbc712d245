"""``python -m sim`` is the ``nhsim`` command."""

from sim.cli.main import console

raise SystemExit(console())
