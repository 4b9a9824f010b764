#!/usr/bin/env bash
# The bash completion script completes subcommands, global options,
# sub-subcommands and option values, from the built `lec`.
: "${LEC6_SOURCE_DIR:?}" "${LEC:?}"
# Completion functions run in the interactive shell: no -e, no -u.
# shellcheck source=/dev/null
source "$LEC6_SOURCE_DIR/tools/completion/lec.bash"

fail=0
# complete_words WORD... : completes the last word of `lec WORD...`, into $got.
complete_words() {
  COMP_WORDS=("$LEC" "$@")
  COMP_CWORD=$#
  COMPREPLY=()
  _lec
  got=" ${COMPREPLY[*]} "
}
expect() {  # expect DESCRIPTION WORD... : the words of COMPREPLY that must be there
  local what=$1
  shift
  local -a line=()
  while [[ $1 != ':' ]]; do line+=("$1"); shift; done
  shift
  complete_words "${line[@]}"
  for w in "$@"; do
    if [[ $got != *" $w "* ]]; then
      echo "FAIL: $what: '$w' not in:$got"
      fail=1
    fi
  done
}
reject() {  # reject DESCRIPTION WORD... : words that must not be there
  local what=$1
  shift
  local -a line=()
  while [[ $1 != ':' ]]; do line+=("$1"); shift; done
  shift
  complete_words "${line[@]}"
  for w in "$@"; do
    if [[ $got == *" $w "* ]]; then
      echo "FAIL: $what: '$w' should not be offered:$got"
      fail=1
    fi
  done
}

expect "subcommands" "" : status move step sim demo
expect "a prefix" "st" : status step stop
reject "a prefix" "st" : move
expect "global options" "--" : --port --baud --json --trace --version
expect "after a global option with its value" --port sim "" : status move
expect "step's subcommands" step "" : list get set backup restore diff
reject "step's subcommands" step "" : status
expect "an option of a subcommand" move "--" : --to --speed --step
expect "baud values" --baud "" : 9600 38400 115200

[[ $fail -eq 0 ]] && echo "completion: subcommands, options and values complete"
exit $fail
