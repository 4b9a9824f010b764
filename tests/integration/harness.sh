# Sourced by every integration script (not a test itself):
#  - `need`: before a test starts its peers, checks that the Python modules
#    and programs it uses are on this machine; if not, names the Debian
#    package and the command that installs it (tools/lec6_preflight.py, from
#    tools/deps.txt) and ends the test with status 1, instead of a traceback
#    halfway through;
#  - `wait_for`: waits for an event (a file, a line, a reply) with a deadline,
#    instead of sleeping and hoping.

LEC6_TOOLS=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../tools" && pwd)

# need [--module MODULE]... [--program PROGRAM]...
need() {
  if [[ ! -x /usr/bin/python3 ]]; then
    echo "lec6 pre-flight: /usr/bin/python3 is missing (Debian's interpreter runs the test scripts)." >&2
    echo "Install it with:  sudo apt-get install -y --no-install-recommends python3   (or: make deps)" >&2
    exit 1
  fi
  /usr/bin/python3 "$LEC6_TOOLS/lec6_preflight.py" "$@" || exit 1
}

# wait_for SECONDS WHAT -- COMMAND...: runs COMMAND every 20 ms until it
# succeeds (returns 0), or until SECONDS have passed: then says what did not
# happen and returns 1.
wait_for() {
  local limit=$1 what=$2
  shift 3
  local start=${EPOCHREALTIME/./}
  local deadline=$((start + ${limit%.*} * 1000000))
  while true; do
    "$@" && return 0
    if ((${EPOCHREALTIME/./} >= deadline)); then
      echo "timed out after ${limit} s waiting for ${what}" >&2
      return 1
    fi
    sleep 0.02
  done
}
