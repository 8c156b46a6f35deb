"""Run a mistakes row's command while something it needs is occupied, as a user would meet it:

    python occupied.py port CMD ...    a server listens on a free port of 127.0.0.1 while CMD
                                       runs; the word PORT in CMD is that port
    python occupied.py twice CMD ...   CMD twice at once (two users, one --out); prints each
                                       one's status and output, and exits 0 when exactly one
                                       succeeded and the other was refused with status 2

The exit status is CMD's (port) or the verdict (twice).
"""

from __future__ import annotations

import socket
import subprocess
import sys


def with_port_taken(command: list[str]) -> int:
    with socket.socket() as server:
        server.bind(('127.0.0.1', 0))
        server.listen()
        port = str(server.getsockname()[1])
        return subprocess.call([port if part == 'PORT' else part for part in command])


def twice_at_once(command: list[str]) -> int:
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True) for _ in range(2)]
    statuses = []
    for k, run in enumerate(runs):
        output, _ = run.communicate()
        statuses.append(run.returncode)
        print(f'--- run {k}: exit status {run.returncode}\n{output}')
    return 0 if sorted(statuses) == [0, 2] else 1


if __name__ == '__main__':
    what, *rest = sys.argv[1:]
    sys.exit({'port': with_port_taken, 'twice': twice_at_once}[what](rest))
