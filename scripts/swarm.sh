#!/usr/bin/env bash
# Run the Mona swarm node system: world, supervisor, metrics and N controllers as real processes
# talking DDS over loopback. Waits for the supervisor to finish, then stops everything.
#
#   scripts/swarm.sh --population 10 --episodes 2 --duration 60 --seed 3 --out results/ros
#
# Across machines: --role core on one host, --role controllers --robots 0-24 on others, each
# with the same --domain and --peers IP,IP (a unicast Fast DDS profile instead of loopback).
#
# The work is done by `mona-swarm launch` (--help lists the options); this finds its Python:
# the repository's .venv, else the python3 of a sourced colcon workspace. With --live the
# live view keeps serving the final state after the run until Ctrl-C (or --linger SECONDS).
# Exit status: 0 if every node succeeded and ended by itself (also after a linger's Ctrl-C);
# 1 if a node failed or had to be stopped; 2 for bad options or parameters; 124 on --timeout;
# 130 / 143 when stopped by SIGINT / SIGTERM.
# See docs/running.md for the output layout, domain ids and the DDS profile.
set -u
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
if [[ -x $REPO/.venv/bin/python ]]; then
  python=$REPO/.venv/bin/python
elif ! python=$(command -v python3) || ! "$python" -c 'import swarm_supervisor' 2>/dev/null
then
  echo "swarm.sh: no .venv (run 'make venv') and no sourced colcon workspace" \
    '(ros_ws/README.md)' >&2
  exit 2
fi
exec "$python" -m swarm_supervisor.cli launch "$@"
