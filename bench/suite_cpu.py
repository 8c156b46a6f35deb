"""Benchmark: where a command's CPU goes, process by process (for ``make test``: by test).

The suite is CPU-bound on a 2-core machine, so its wall time is its CPU time over two; to cut
it, one must know which processes spend the CPU. pytest's own timings cannot say (a test's
wall time includes its wait for a saturated machine, and a plug-in's rusage misses processes
nobody reaps, such as the browser's). This runs the command under the kernel's process
accounting (``accton``, Debian's ``acct``: one record with the CPU time of every process that
exits) and, through a ``sitecustomize`` module on PYTHONPATH, logs every Python process's
command line and the test running when it started (pytest's PYTEST_CURRENT_TEST, which child
processes inherit). Each process is then charged to the test of its nearest logged ancestor.

    sudo .venv/bin/python bench/suite_cpu.py [--out DIR] -- make test

Prints the total CPU, the CPU by kind of process (a console script, ``-m module``, a spawned
pool worker, or the kernel's name for a process that logged no start: chromium, a worker
forked from a fork server) and by test (its child processes); DIR keeps the raw records.
Needs root and ``acct`` (``apt-get install acct``). A benchmark, not a test: the numbers
depend on the machine.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Logs each Python process as it starts (a sitecustomize module runs in every interpreter
#: that has it on its path); it must never fail the process it runs in.
HOOK = """
import json, os, sys
try:
    fd = os.open({log!r}, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    os.write(fd, (json.dumps({{'pid': os.getpid(), 'ppid': os.getppid(),
                              'argv': list(getattr(sys, 'orig_argv', []))[:10],
                              'test': os.environ.get('PYTEST_CURRENT_TEST')}}) + '\\n').encode())
    os.close(fd)
except Exception:
    pass
"""


def read_accounting(path: Path) -> dict[int, tuple[str, float, int]]:
    """pid -> (kernel's process name, CPU seconds, parent pid), from ``dump-acct``."""
    text = subprocess.run(['dump-acct', str(path)], capture_output=True, text=True,
                          check=True).stdout
    found = {}
    for line in text.splitlines():
        fields = [field.strip() for field in line.split('|')]
        if len(fields) >= 11:  # comm|v3|utime|stime|etime|uid|gid|mem|io|pid|ppid|...
            found[int(fields[9])] = (fields[0], (float(fields[2]) + float(fields[3])) / 100,
                                     int(fields[10]))
    return found


def kind(argv: list[str]) -> str:
    """A short name for what a Python process ran."""
    line = ' '.join(argv)
    if 'spawn_main' in line or 'forkserver' in line:
        return 'multiprocessing (a spawned worker or a fork server)'
    if 'execnet' in line or (len(argv) > 1 and argv[1] == '-u'):
        return 'pytest-xdist worker'
    module = re.search(r'(?:^| )-m (\S+)', line)
    if module:
        return '-m ' + module.group(1)
    if len(argv) > 1 and not argv[1].startswith('-'):
        return Path(argv[1]).name + (f' {argv[2]}' if len(argv) > 2 and
                                     not argv[2].startswith('-') and '/' not in argv[2] else '')
    return '-c (inline)' if '-c' in argv else line[:40]


Table = dict[str, float]


def summarise(accounting: dict[int, tuple[str, float, int]], started: dict[int, dict]
              ) -> tuple[float, Table, Table, Table]:
    """(total CPU, CPU by kind, processes by kind, child CPU by test)."""
    by_kind: Table = collections.defaultdict(float)
    count: Table = collections.defaultdict(float)
    by_test: Table = collections.defaultdict(float)
    for pid, (name, cpu, _) in accounting.items():
        what = kind(started[pid]['argv']) if pid in started else name
        by_kind[what] += cpu
        count[what] += 1
        ancestor, hops = pid, 0
        while ancestor and hops < 64:  # the nearest logged ancestor that knows its test
            entry = started.get(ancestor)
            if entry and entry.get('test') and what != 'pytest-xdist worker':
                by_test[entry['test'].rsplit(' (', 1)[0]] += cpu
                break
            ancestor = (accounting[ancestor][2] if ancestor in accounting
                        else entry['ppid'] if entry else 0)
            hops += 1
    return sum(cpu for _, cpu, _ in accounting.values()), by_kind, count, by_test


def largest(table: Table, top: int) -> list[tuple[str, float]]:
    return sorted(table.items(), key=lambda row: -row[1])[:top]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--out', type=Path, help='keep the raw records here')
    parser.add_argument('--top', type=int, default=40, help='rows of each table')
    parser.add_argument('command', nargs=argparse.REMAINDER, help='-- COMMAND ...')
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ['--'] else args.command
    if not command:
        parser.error('give the command after --, e.g. -- make test')
    out = args.out or Path(tempfile.mkdtemp(prefix='suite-cpu-'))
    out.mkdir(parents=True, exist_ok=True)
    log, pacct, hook = out / 'started.jsonl', out / 'pacct', out / 'hook'
    hook.mkdir(exist_ok=True)
    (hook / 'sitecustomize.py').write_text(HOOK.format(log=str(log)))
    for path in (log, pacct):
        path.write_bytes(b'')
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        filter(None, [str(hook), os.environ.get('PYTHONPATH')])))
    subprocess.run(['accton', str(pacct)], check=True, capture_output=True)
    try:
        status = subprocess.run(command, env=env).returncode
        time.sleep(2.0)  # what outlives the command by a moment (a pool's fork server)
    finally:
        subprocess.run(['accton', 'off'], capture_output=True)
    started = {}
    for line in log.read_text().splitlines():
        try:
            entry = json.loads(line)
        except ValueError:
            continue
        started[entry['pid']] = entry
    total, by_kind, count, by_test = summarise(read_accounting(pacct), started)
    print(f'\n{total:.0f} CPU-s in all ({command!r} exited {status}); records in {out}')
    print('\nCPU-s  processes  kind')
    for what, cpu in largest(by_kind, args.top):
        print(f'{cpu:7.1f} {count[what]:6.0f}  {what}')
    print('\nCPU-s of its processes  test')
    for test, cpu in largest(by_test, args.top):
        print(f'{cpu:7.1f}  {test}')
    return status


if __name__ == '__main__':
    sys.exit(main())
