# bash completion for `lec` (installed as /usr/share/bash-completion/completions/lec).
#
# The options and subcommands come from `lec ... --help` of the installed
# binary at completion time, so this file never goes out of date.

_lec_help_words() {
  # $1: the help text. Prints option names and subcommand names.
  local section="" line word
  while IFS= read -r line; do
    case "$line" in
      Options:*) section=options; continue ;;
      Subcommands:*) section=subcommands; continue ;;
      "") section=""; continue ;;
    esac
    [[ $line == "  "[!\ ]* ]] || continue
    line=${line#  }
    case $section in
      options)
        # "-p,--port TEXT ..." → -p --port
        word=${line%% *}
        tr ',' '\n' <<<"$word"
        ;;
      subcommands)
        echo "${line%% *}"
        ;;
    esac
  done <<<"$1"
}

_lec() {
  local cur prev
  cur=${COMP_WORDS[COMP_CWORD]}
  prev=${COMP_WORDS[COMP_CWORD - 1]}

  # The subcommand path so far (words that are not options or option values).
  local -a path=()
  local i word help words
  local lec=${COMP_WORDS[0]}
  for ((i = 1; i < COMP_CWORD; i++)); do
    word=${COMP_WORDS[i]}
    [[ $word == -* ]] && continue
    # A value of the option before it? Options that take a value show one in --help.
    if [[ ${COMP_WORDS[i - 1]} == -* ]]; then
      help=$("$lec" "${path[@]}" --help 2>/dev/null)
      if grep -Eq -- "(^|[ ,])${COMP_WORDS[i - 1]}( [A-Z]|:)" <<<"$help"; then continue; fi
    fi
    help=$("$lec" "${path[@]}" --help 2>/dev/null)
    if _lec_help_words "$help" | grep -qx -- "$word"; then path+=("$word"); fi
  done

  case $prev in
    --port | -p)
      COMPREPLY=($(compgen -W "sim tcp://" -- "$cur") $(compgen -f -- "${cur:-/dev/tty}"))
      return
      ;;
    --baud | -b)
      COMPREPLY=($(compgen -W "9600 19200 38400 57600 115200 230400" -- "$cur"))
      return
      ;;
    --record | --state | --pty)
      COMPREPLY=($(compgen -f -- "$cur"))
      return
      ;;
  esac

  help=$("$lec" "${path[@]}" --help 2>/dev/null) || help=""
  words=$(_lec_help_words "$help")
  if [[ $cur == -* ]]; then
    COMPREPLY=($(compgen -W "$(grep -- '^-' <<<"$words")" -- "$cur"))
  else
    COMPREPLY=($(compgen -W "$(grep -v -- '^-' <<<"$words")" -- "$cur"))
    # Commands that take files (step backup/restore/diff).
    if ((${#COMPREPLY[@]} == 0)); then COMPREPLY=($(compgen -f -- "$cur")); fi
  fi
}

complete -F _lec lec
