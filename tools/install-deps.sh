#!/usr/bin/env bash
# Installs the Debian packages of tools/deps.txt that are missing (`make deps`).
# `apt-get update` runs once, and only when something has to be installed;
# --no-install-recommends, as the list counts hard Depends only (tools/check-deps).
# For alternatives `a | b`: nothing to do when one is installed (or provided by
# an installed package); otherwise the first one apt can install.
#
#   tools/install-deps.sh [--dry-run] [LIST]   (default: tools/deps.txt beside this script)
#
# --dry-run: only say what is missing (exit 1 if anything is); no apt at all.
set -euo pipefail

dry_run=0
if [[ ${1:-} == --dry-run ]]; then
  dry_run=1
  shift
fi
list=${1:-$(dirname "$0")/deps.txt}
[[ -r $list ]] || { echo "install-deps: cannot read $list" >&2; exit 2; }

# Installed packages and the names they provide.
declare -A present=()
while read -r name; do present[$name]=1; done < <(
  dpkg-query -W -f='${Status}\t${Package}\t${Provides}\n' 2>/dev/null |
    awk -F'\t' '$1 ~ / installed$/ { print $2; n = split($3, p, /, */); for (i = 1; i <= n; i++) { sub(/ .*/, "", p[i]); if (p[i] != "") print p[i] } }')

groups=()  # missing entries: "a b" for `a | b`
while IFS= read -r line; do
  line=${line%%#*}
  line=${line//|/ }
  read -r -a alternatives <<<"$line"
  ((${#alternatives[@]})) || continue
  line=${alternatives[*]}
  found=0
  for p in "${alternatives[@]}"; do [[ -n ${present[$p]:-} ]] && found=1 && break; done
  ((found)) || groups+=("$line")
done <"$list"

if ((${#groups[@]} == 0)); then
  ((dry_run == 0)) || echo "install-deps: nothing missing from $list"
  exit 0
fi

printf -v shown "%s; " "${groups[@]// / | }"
echo "install-deps: missing from $list: ${shown%; }"
((dry_run == 0)) || exit 1
sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
$sudo apt-get update -qq

installable() { [[ $(apt-cache policy "$1" 2>/dev/null | sed -n 's/^ *Candidate: *//p') =~ ^[0-9] ]]; }
install=()
for g in "${groups[@]}"; do
  pick=""
  for p in $g; do
    if installable "$p"; then pick=$p && break; fi
  done
  [[ -n $pick ]] || { echo "install-deps: none of '$g' can be installed from the configured apt sources" >&2; exit 1; }
  install+=("$pick")
done
echo "install-deps: apt-get install ${install[*]}"
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${install[@]}"
