"""The exit statuses of every command (``mona-swarm``, ``scripts/swarm.sh``, the nodes), named
once."""

OK = 0  #: every promised output is complete
FAILED = 1  #: a run, a node or a record failed (an incomplete bag, a node that crashed)
USAGE = 2  #: a bad option, parameter or input: named in one line, nothing started
TIMEOUT = 124  #: ``--timeout`` (or ``run --wait-for-viewer``) ran out (as timeout(1))
INTERRUPTED = 130  #: stopped by SIGINT (Ctrl-C)
TERMINATED = 143  #: stopped by SIGTERM

#: The statuses, for the epilog of every ``--help``.
HELP = (f'exit status: {OK} success (every output complete), {FAILED} a run, node or record '
        f'failed, {USAGE} a bad option, parameter or input (nothing written), {TIMEOUT} '
        f'--timeout (or --wait-for-viewer) ran out, {INTERRUPTED} / {TERMINATED} stopped by '
        'SIGINT / SIGTERM')
