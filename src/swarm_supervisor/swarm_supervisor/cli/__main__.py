"""``python -m swarm_supervisor.cli``: the ``mona-swarm`` command (scripts/swarm.sh uses it)."""

import sys

from swarm_supervisor.cli.command import main

sys.exit(main())
