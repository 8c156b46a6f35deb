#!/usr/bin/env bash
# The tools make test needs beyond the venv (make firmware-tools, make browser-tools):
#   tests/install-tools.sh firmware   the firmware's Debian toolchain and simulator (docs/link.md)
#   tests/install-tools.sh browser    Debian's chromium and the Foxglove web build (docs/bags.md)
#   tests/install-tools.sh foxglove   the Foxglove web build alone
#   tests/install-tools.sh system     iproute2, for the node system across network namespaces
# Quick when present (dpkg-query, and a hash of the app's package.json and lock: 0.1 s).
# Under CI=true a tool either installs or this exits 1, naming the tool, the command that
# failed and the tail of its output. Elsewhere (a laptop without root) it only says so and
# exits 0: the tests that need the tool then skip, and make test ends with a banner listing
# them (tests/conftest.py).
set -u

what=${1:-}
case "$what" in
  firmware) packages='gcc-avr avr-libc simavr libsimavr-dev libsimavrparts1 libelf-dev pkg-config'
            tests='the firmware tests' ;;
  browser)  packages='chromium fonts-dejavu-core'
            tests='the browser tests' ;;
  foxglove) packages=
            tests='the browser tests' ;;
  system)   packages='iproute2'
            tests='the network-namespace test (tests/system/test_netns.py)' ;;
  *) echo "usage: $0 firmware|browser|foxglove|system" >&2; exit 2 ;;
esac
name="${what/foxglove/browser}-tools"
case "${CI:-}" in ''|false|0|no) strict= ;; *) strict=1 ;; esac
APP=$(cd "$(dirname "$0")" && pwd)/browser/app
CACHE=${FOXGLOVE_CACHE:-${MONA_SWARM_FOXGLOVE_CACHE:-$HOME/.cache/mona-swarm/foxglove}}

# A tool that could not be installed: under CI the run fails here, elsewhere the tests skip.
give_up() {  # give_up WHAT [LOG]
  echo "$name: $1" >&2
  if [ -n "${2:-}" ] && [ -s "$2" ]; then
    echo "$name: the last lines of its output:" >&2
    tail -n 20 "$2" | sed 's/^/    /' >&2
  fi
  if [ -n "$strict" ]; then
    echo "$name: FAILED (CI=$CI: a tool make test needs must install)" >&2
    exit 1
  fi
  echo "$name: $tests will skip (make test lists them at the end)" >&2
  exit 0
}

log=$(mktemp "${TMPDIR:-/tmp}/$name.XXXXXX.log")
trap 'rm -f "$log"' EXIT

# --- Debian packages -------------------------------------------------------------------------
# npm (the Foxglove build's installer) from Debian only where there is none (NodeSource's
# nodejs package brings its own)
case "$what" in browser|foxglove) ! command -v npm >/dev/null && packages="$packages npm" ;; esac
missing=
if [ -n "${packages// /}" ] && ! command -v dpkg-query >/dev/null; then
  give_up "no dpkg-query: install the Debian packages ${packages# } by hand"
fi
for package in $packages; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'install ok installed' ||
    missing="$missing $package"
done
missing=${missing# }
if [ -n "$missing" ]; then
  if [ "$(id -u)" = 0 ]; then sudo=
  elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then sudo='sudo -n'
  else give_up "missing $missing: not root and no sudo (sudo make $name installs them)"
  fi
  install="${sudo:+$sudo }apt-get install -y --no-install-recommends $missing"
  echo "$name: $install"
  # One apt-get at a time (make test runs the tools' targets side by side): a lock of ours,
  # since apt-get does not wait for a dpkg lock another apt-get holds (by default).
  run_apt() {
    flock "${TMPDIR:-/tmp}/mona-swarm-apt.lock" \
      $sudo env DEBIAN_FRONTEND=noninteractive apt-get "$@" >>"$log" 2>&1
  }
  if ! run_apt install -y --no-install-recommends $missing; then
    # A fresh machine's package lists may be stale or empty: update once, then retry.
    run_apt update -q && run_apt install -y --no-install-recommends $missing ||
      give_up "\`$install\` failed (also after apt-get update)" "$log"
  fi
fi
case "$what" in firmware|system) exit 0 ;; esac

# --- the Foxglove web build, from npm into a cache outside the checkout ---------------------
# Keyed by the content of package.json and package-lock.json together: a change to either
# reinstalls.
key=$(cat "$APP/package.json" "$APP/package-lock.json" | sha256sum | cut -d' ' -f1)
bundle="$CACHE/node_modules/@foxglove/studio-base/assets/index.js"
if [ "$(cat "$CACHE/.installed-key" 2>/dev/null)" = "$key" ] && [ -e "$bundle" ]; then
  exit 0
fi
echo "$name: npm ci (tests/browser/app/package.json and its lock) into $CACHE"
mkdir -p "$CACHE" && rm -f "$CACHE/.installed-key" &&
  cp "$APP/package.json" "$APP/package-lock.json" "$CACHE/" ||
  give_up "cannot copy tests/browser/app/package.json and its lock into $CACHE"
(cd "$CACHE" && npm ci --no-audit --no-fund --loglevel=error) >"$log" 2>&1 ||
  give_up "\`npm ci\` of tests/browser/app/package.json and its lock (in $CACHE) failed" "$log"
[ -e "$bundle" ] || give_up "npm ci left no $bundle" "$log"
echo "$key" >"$CACHE/.installed-key"
