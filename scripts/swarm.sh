#!/usr/bin/env bash
# Run the Mona swarm node system: world, supervisor, metrics and N controllers as real processes
# talking DDS over loopback. Waits for the supervisor to finish, then stops everything.
#
#   scripts/swarm.sh --population 10 --episodes 2 --duration 60 --seed 3 --out results/ros
#
# Exit status: 0 if every node succeeded and ended by itself, which includes every episode's bag
# closed and complete (the supervisor checks the metrics node's report); 1 if a node failed or
# had to be stopped (the message names it); 2 for bad options or parameters; 124 on --timeout; 130 / 143 when stopped by SIGINT / SIGTERM.
# See docs/running.md for the output layout, domain ids and the DDS profile.
set -uo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PROG=swarm.sh

usage() {
  cat <<EOF
usage: scripts/swarm.sh [options]
  --population N              robots (default: the config's episode.population)
  --speed CM_S                robot speed in cm/s (sets controller.speed = CM_S / 100 m/s)
  --episodes E                episodes to run one after the other (default 1)
  --duration S                simulated seconds per episode (default: episode.duration)
  --seed S                    seed of the first episode (default: episode.seed)
  --out DIR                   output folder (default results/swarm-<date>-<time>)
  --mode lockstep|realtime    stepping (default lockstep)
  --config YAML               parameter file (default ros_ws/config/mona_swarm.yaml)
  --controllers-per-process K robots per controller process, one node each (default 1)
  --timeout S                 wall-clock limit for the whole run, 0 = none (default 0)
  --start-timeout S           how long the world waits for every controller and the metrics
                              node to be ready for an episode (default max(60, 3 N) s)
  -p NAME:=VALUE              extra ROS parameter override for every node (repeatable)
Environment: SWARM_DOMAIN_ID forces the ROS domain id; SWARM_FASTDDS_PROFILE another profile.
EOF
}

die() { echo "$PROG: $*" >&2; exit 2; }
say() { echo "$PROG: $*" >&2; }

# --- options -----------------------------------------------------------------------------------
population='' speed='' episodes=1 duration='' seed='' out='' mode=lockstep
config="$REPO/ros_ws/config/mona_swarm.yaml" per_process=1 timeout=0 start_timeout=''
extra=()
while (($#)); do
  case $1 in
    --population) population=${2-}; shift ;;
    --speed) speed=${2-}; shift ;;
    --episodes) episodes=${2-}; shift ;;
    --duration) duration=${2-}; shift ;;
    --seed) seed=${2-}; shift ;;
    --out) out=${2-}; shift ;;
    --mode) mode=${2-}; shift ;;
    --config) config=${2-}; shift ;;
    --controllers-per-process) per_process=${2-}; shift ;;
    --timeout) timeout=${2-}; shift ;;
    --start-timeout) start_timeout=${2-}; shift ;;
    -p) extra+=(-p "${2-}"); shift ;;
    -h|--help) usage; exit 0 ;;
    *) usage >&2; die "unknown option '$1'" ;;
  esac
  shift
done
is_uint() { [[ $1 =~ ^[0-9]+$ ]]; }
is_number() { [[ $1 =~ ^[0-9]+([.][0-9]*)?([eE][-+]?[0-9]+)?$ ]]; }
[[ -z $population ]] || is_uint "$population" || die "--population '$population': expected a whole number"
[[ -z $speed ]] || is_number "$speed" || die "--speed '$speed': expected cm/s, e.g. 8"
[[ -z $duration ]] || is_number "$duration" || die "--duration '$duration': expected seconds"
[[ -z $seed ]] || is_uint "$seed" || die "--seed '$seed': expected a whole number"
is_uint "$episodes" && ((episodes >= 1)) || die "--episodes '$episodes': expected 1 or more"
is_uint "$per_process" && ((per_process >= 1)) || die "--controllers-per-process '$per_process': expected 1 or more"
is_uint "$timeout" || die "--timeout '$timeout': expected whole seconds"
[[ -z $start_timeout ]] || { is_uint "$start_timeout" && ((start_timeout >= 1)); } || die "--start-timeout '$start_timeout': expected whole seconds, 1 or more"
[[ $mode == lockstep || $mode == realtime ]] || die "--mode '$mode': expected lockstep or realtime"
[[ -f $config ]] || die "--config '$config': no such file"
config=$(cd "$(dirname "$config")" && pwd)/$(basename "$config")

# --- executables: the repository's venv, else a sourced colcon workspace -----------------------
if [[ -x $REPO/.venv/bin/python ]]; then
  PATH="$REPO/.venv/bin:$PATH"
  python="$REPO/.venv/bin/python"
else
  python=$(command -v python3) || die 'no .venv (run make venv) and no python3'
fi
find_exe() {  # package executable -> path
  local prefix
  if command -v "$2" >/dev/null; then command -v "$2"; return; fi
  IFS=: read -ra prefixes <<<"${AMENT_PREFIX_PATH-}"
  for prefix in "${prefixes[@]}"; do
    [[ -x $prefix/lib/$1/$2 ]] && { echo "$prefix/lib/$1/$2"; return; }
  done
  die "cannot find $2 ($1): run 'make venv', or source a colcon workspace (ros_ws/README.md)"
}
world_exe=$(find_exe swarm_world world_node) || exit 2
controller_exe=$(find_exe mona_controller mona_controller_node) || exit 2
supervisor_exe=$(find_exe swarm_supervisor supervisor_node) || exit 2
metrics_exe=$(find_exe swarm_metrics metrics_node) || exit 2

# --- the run's parameters: the one YAML plus overrides, checked before any node starts -------
overrides=()
[[ -n $population ]] && overrides+=(-p "episode.population:=$population")
[[ -n $duration ]] && overrides+=(-p "episode.duration:=$duration")
[[ -n $seed ]] && overrides+=(-p "episode.seed:=$seed")
[[ -n $speed ]] && overrides+=(-p "controller.speed:=$("$python" -c "print(repr($speed / 100))")")
overrides+=("${extra[@]}")
# Validates with the same schema as the nodes; prints the population the run needs.
population=$("$python" - "$config" "${overrides[@]}" <<'EOF'
import sys, yaml
from mona_controller.schema import ParameterError
from swarm_supervisor.config import load_config
try:
    config = load_config(sys.argv[1])
    sections = {}
    args = sys.argv[2:]
    for flag, value in zip(args[::2], args[1::2]):
        name, _, text = value.partition(':=')
        section, _, key = name.partition('.')
        if key and hasattr(config, section):
            sections.setdefault(section, {})[key] = yaml.safe_load(text)
    config = config.replace(**sections)
except ParameterError as error:
    sys.exit(f'swarm.sh: bad parameter: {error}')
if config.episode.population < 1:
    sys.exit('swarm.sh: bad parameter: episode.population = 0: a ros run needs a robot')
print(config.episode.population)
EOF
) || exit 2

# --- the output folder
out=${out:-$REPO/results/swarm-$(date +%Y%m%d-%H%M%S)}
mkdir -p "$out/logs" || die "cannot create '$out/logs'"
out=$(cd "$out" && pwd)

# --- a private ROS domain: locked for the run's lifetime, ports unused ------------------------
domain_ports_free() {
  local base=$((7400 + 250 * $1)) port
  command -v ss >/dev/null || return 0
  for port in $base $((base + 10)) $((base + 12)); do
    [[ -z $(ss -Hauln "sport = :$port" 2>/dev/null) ]] || return 1
  done
}
take_domain() {  # domain id -> holds /tmp/mona-ros-domain-<id>.lock on fd $lock_fd
  exec {lock_fd}>"/tmp/mona-ros-domain-$1.lock" || return 1
  if flock -n "$lock_fd" && domain_ports_free "$1"; then return 0; fi
  exec {lock_fd}>&-
  return 1
}
lock_fd=''
if [[ -n ${SWARM_DOMAIN_ID-} ]]; then
  is_uint "$SWARM_DOMAIN_ID" && ((SWARM_DOMAIN_ID <= 232)) || die "SWARM_DOMAIN_ID '$SWARM_DOMAIN_ID': expected 0..232"
  domain=$SWARM_DOMAIN_ID  # the caller's choice (and responsibility): no lock, no check
else
  # Domains 1..100 keep every port below Linux's ephemeral range; start from our pid.
  domain=''
  for ((k = 0; k < 100; k++)); do
    candidate=$(( ($$ + k) % 100 + 1 ))
    if take_domain "$candidate"; then domain=$candidate; break; fi
  done
  [[ -n $domain ]] || die 'no free ROS domain id in 1..100'
fi

export ROS_DOMAIN_ID=$domain
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
export FASTRTPS_DEFAULT_PROFILES_FILE=${SWARM_FASTDDS_PROFILE:-$REPO/ros_ws/config/fastdds_localhost.xml}
export ROS_LOG_DIR=$out/logs/ros
export PYTHONUNBUFFERED=1 PYTHONFAULTHANDLER=1
ulimit -c 0  # no core files from the SIGABRT of a stuck node
export RCUTILS_LOGGING_BUFFERED_STREAM=0
unset ROS_AUTOMATIC_DISCOVERY_RANGE ROS_LOCALHOST_ONLY ROS_STATIC_PEERS
cat >"$out/ros_env.sh" <<EOF
# source this file to reach the run from another shell (ros2 topic echo, rviz2, ...)
export ROS_DOMAIN_ID=$ROS_DOMAIN_ID
export RMW_IMPLEMENTATION=$RMW_IMPLEMENTATION
export FASTRTPS_DEFAULT_PROFILES_FILE=$FASTRTPS_DEFAULT_PROFILES_FILE
unset ROS_AUTOMATIC_DISCOVERY_RANGE ROS_LOCALHOST_ONLY
EOF

# --- processes ---------------------------------------------------------------------------------
names=() pids=()
declare -A status=() stopped=() forced=()
: >"$out/processes.tsv"

start() {  # name command... : its own session and process group, output to logs/<name>.log
  local name=$1; shift
  # Background jobs of a script start with SIGINT ignored; the nodes must see it. The children
  # inherit the domain lock: the domain stays taken while any of them lives.
  env --default-signal=INT,QUIT setsid "$@" >"$out/logs/$name.log" 2>&1 </dev/null &
  names+=("$name") pids+=($!)
  printf '%s\t%s\t%s\n' "$name" "$!" "$*" >>"$out/processes.tsv"
}
alive() { kill -0 "$1" 2>/dev/null; }
live_indices() {  # indices of the processes still running
  local i
  for i in "${!pids[@]}"; do alive "${pids[$i]}" && echo "$i"; done
}
signal_groups() {  # signal indices...
  local sig=$1 i; shift
  for i in "$@"; do kill -s "$sig" -- "-${pids[$i]}" 2>/dev/null; done
}
wait_gone() {  # seconds indices... : true once none of them runs
  local deadline=$((SECONDS + $1)) i running; shift
  while :; do
    running=''
    for i in "$@"; do alive "${pids[$i]}" && { running=1; break; }; done
    [[ -z $running ]] && return 0
    ((SECONDS < deadline)) || return 1
    [[ -n $polite && -n $stopping ]] && return 1  # a signal cuts a polite wait short
    sleep 0.2
  done
}
stop_all() {  # SIGINT, SIGTERM, SIGABRT, SIGKILL: each to the process groups still running
  local -a live
  local i
  note_shm
  mapfile -t live < <(live_indices)
  ((${#live[@]})) || return 0
  for i in "${live[@]}"; do stopped[$i]=SIGINT; done
  signal_groups INT "${live[@]}"
  wait_gone 20 "${live[@]}" && return 0
  mapfile -t live < <(live_indices)
  for i in "${live[@]}"; do forced[$i]=SIGTERM; done
  say "SIGTERM to ${#live[@]} process(es) still running 20 s after SIGINT"
  signal_groups TERM "${live[@]}"
  wait_gone 5 "${live[@]}" && return 0
  # Stuck in native code, where Python's handlers never run: SIGABRT makes the fault handler
  # write every thread's Python stack to the node's log before the process dies.
  mapfile -t live < <(live_indices)
  for i in "${live[@]}"; do forced[$i]=SIGABRT; done
  say "SIGABRT to ${#live[@]} process(es) still running 5 s after SIGTERM (stacks in their logs)"
  signal_groups ABRT "${live[@]}"
  wait_gone 3 "${live[@]}" && return 0
  mapfile -t live < <(live_indices)
  for i in "${live[@]}"; do forced[$i]=SIGKILL; done
  say "SIGKILL to ${#live[@]} process(es) still running 3 s after SIGABRT"
  signal_groups KILL "${live[@]}"
  wait_gone 5 "${live[@]}"
  # Anything left in a group whose leader is gone.
  signal_groups KILL "${!pids[@]}"
}
shm_seen=''
note_shm() {  # remember the Fast DDS /dev/shm files our processes map (a killed one can't tell)
  local i
  for i in $(live_indices); do
    shm_seen+=$'\n'$(grep -ho '/dev/shm/fast[^ ]*' "/proc/${pids[$i]}/maps" 2>/dev/null)
  done
}
clean_shm() {  # remove our Fast DDS files from /dev/shm: the port files of our domain (their
  # names carry the port) and the files our processes mapped, unless some process uses them
  local name port ours used low=$((7400 + 250 * domain))
  used=$( (cat /proc/[0-9]*/maps; ls -l /proc/[0-9]*/fd) 2>/dev/null | grep -o '/dev/shm/[^ ]*')
  for name in $(ls /dev/shm 2>/dev/null); do
    [[ $name == fastrtps_* || $name == fast_datasharing* || $name == sem.fastrtps_* ]] || continue
    port=$(grep -o 'port[0-9]*' <<<"$name" | head -1); port=${port#port}
    ours=''
    grep -qxF "/dev/shm/$name" <<<"$shm_seen" && ours=1
    [[ -n $port ]] && ((port >= low && port < low + 250)) && ours=1
    [[ -n $ours ]] || continue
    grep -qxF "/dev/shm/$name" <<<"$used" && continue   # in use by a live process
    rm -f "/dev/shm/$name"
  done
}
collect() {  # record the exit status of every process that ended (bash keeps it for wait)
  local i
  for i in "${!pids[@]}"; do
    [[ -n ${status[$i]-} ]] && continue
    alive "${pids[$i]}" && continue
    wait "${pids[$i]}" 2>/dev/null
    status[$i]=$?
  done
}
describe() {  # status -> words
  local s=$1
  if ((s > 128 && s < 160)); then echo "killed by SIG$(kill -l $((s - 128)))"
  else echo "exit status $s"; fi
}

stopping='' polite=''
trap 'stopping=SIGINT' INT
trap 'stopping=SIGTERM' TERM
trap 'stop_all; clean_shm' EXIT  # also on an unexpected error in this script

ros_args=(--ros-args --params-file "$config" "${overrides[@]}")
say "domain $domain, $population robots, $episodes episode(s), $mode, output $out"

# Starting many Python processes takes a while on a small machine: scale the world's patience.
start_timeout=${start_timeout:-$((population * 3 > 60 ? population * 3 : 60))}
start world "$world_exe" "${ros_args[@]}" -p "mode:=$mode" -p "output_dir:=$out" \
  -p "start_timeout:=$start_timeout.0" -p recorders:=metrics
start metrics "$metrics_exe" "${ros_args[@]}" -p "output_dir:=$out"
for ((first = 0; first < population; first += per_process)); do
  last=$((first + per_process - 1)); ((last < population)) || last=$((population - 1))
  robots=$first; ((last > first)) && robots=$first-$last
  start "controller_$robots" "$controller_exe" --robots "$robots" "${ros_args[@]}"
done
start supervisor "$supervisor_exe" "${ros_args[@]}" -p "episodes:=$episodes" \
  -p "output_dir:=$out" -p recorders:=metrics
supervisor=$((${#pids[@]} - 1))

# Wait for the supervisor. The run cannot go on without the world or the metrics node; a
# controller that dies is the world's business (it counts the misses) and fails the run later.
started=$SECONDS
outcome='' quiet_end=''
while [[ -z $stopping && -z $outcome ]]; do
  sleep 0.5
  collect
  if [[ -n ${status[$supervisor]-} ]]; then
    ((status[$supervisor] == 0)) && outcome=finished || outcome=failed
  fi
  for i in 0 1; do  # world, metrics: a clean end comes with the supervisor's
    [[ -z $outcome && -n ${status[$i]-} ]] || continue
    if ((status[$i] != 0)) || ((quiet_end && SECONDS - quiet_end > 10)); then
      say "${names[$i]} ended ($(describe "${status[$i]}")) during the run: stopping the run"
      outcome=failed
    fi
    quiet_end=${quiet_end:-$SECONDS}
  done
  ((SECONDS % 10)) || note_shm
  if [[ -z $outcome ]] && ((timeout > 0 && SECONDS - started > timeout)); then
    say "no result after the --timeout of ${timeout} s: stopping the run"
    outcome=timeout
  fi
done
[[ -n $stopping ]] && say "$stopping received: stopping every node"

polite=1
if [[ $outcome == finished ]]; then
  # After the shutdown announcement the nodes end by themselves; give them time to.
  mapfile -t live < <(live_indices)
  ((${#live[@]})) && wait_gone 30 "${live[@]}"
elif [[ $outcome == failed && -n ${status[0]-} ]] && alive "${pids[1]}"; then
  # The world is gone: the metrics node notices by itself and closes the bag.
  say "waiting up to 30 s for the metrics node to notice and close its bag"
  wait_gone 30 1
fi
polite=''
stop_all
collect
clean_shm
trap - EXIT INT TERM

# The verdict, process by process.
failures=0
for i in "${!pids[@]}"; do
  s=${status[$i]-unknown} what="${names[$i]} (pid ${pids[$i]})"
  log="see $out/logs/${names[$i]}.log"
  if [[ -n ${forced[$i]-} ]]; then
    say "FAILED $what: did not stop on SIGINT, ended by ${forced[$i]}; $log"; ((failures++))
  elif [[ -n ${stopped[$i]-} ]]; then
    # Stopped by us: fine after an interrupt or another node's failure. After a finished run
    # it should have ended by itself on the shutdown announcement: one that had to be stopped
    # may not have closed its outputs, so the run is not reported complete.
    if [[ $outcome == finished ]]; then
      say "FAILED $what: did not end by itself after the shutdown; stopped by SIGINT; $log"
      ((failures++))
    fi
  elif [[ $s != 0 ]]; then
    say "FAILED $what: $(describe "$s"); $log"; ((failures++))
    reason=$(grep -E '^\[(ERROR|FATAL)\]' "$out/logs/${names[$i]}.log" 2>/dev/null | tail -n 1)
    [[ -n $reason ]] && say "  its last error: ${reason#*]: }"
  fi
done
case $outcome in
  finished) ((failures)) && exit 1; say "done: $out"; exit 0 ;;
  failed) exit 1 ;;
  timeout) exit 124 ;;
esac
[[ $stopping == SIGINT ]] && exit 130
exit 143
