# Bash completion for dembuf and dembufd: commands and options are read from the programs'
# own --help when Tab is pressed, and the values of --preset, --accuracy, --format, --set and
# --vary from `dembuf scene --list`, so they follow the binaries installed. Install with
#   cp deploy/dembuf-completion.bash /usr/share/bash-completion/completions/dembuf
#   ln -s dembuf /usr/share/bash-completion/completions/dembufd
# or source it from ~/.bashrc.

# The commands of PROGRAM [COMMAND...] (the names on the lines under "Subcommands:", each
# alias of "  bed, beds   ..." too).
_dembuf_commands() {
  "$@" --help 2>/dev/null | awk '/^Subcommands:/ { in_list = 1; next }
                                 in_list && /^  [a-z]/ { sub(/^  /, ""); split($0, part, /   */)
                                                         n = split(part[1], names, /, */)
                                                         for (i = 1; i <= n; i++) print names[i] }
                                 in_list && /^$/ { in_list = 0 }'
}

# The options in a --help text ("  -q,--quiet ..." gives -q and --quiet).
_dembuf_options() {
  sed -n 's/^  \(-[^ ]*\).*/\1/p' | tr ',' '\n'
}

# The options in a --help text that take a value ("  --server TEXT ...").
_dembuf_valued_options() {
  sed -n 's/^  \(-[^ ]*\) [A-Z][A-Z]*.*/\1/p' | tr ',' '\n'
}

_dembuf() {
  local program=${COMP_WORDS[0]} current=${COMP_WORDS[COMP_CWORD]} word previous=""
  local commands valued
  local -a command=()  # the command and its subcommands given so far ("bed export")
  commands=$(_dembuf_commands "$program")
  valued=$("$program" --help 2>/dev/null | _dembuf_valued_options)
  # The command is the first word that names one, not the value of an option before it; then
  # each word that names one of its subcommands.
  for word in "${COMP_WORDS[@]:1:COMP_CWORD-1}"; do
    if ! grep -qxF -- "$previous" <<< "$valued" && grep -qxF -- "$word" <<< "$commands"; then
      command+=("$word")
      commands=$(_dembuf_commands "$program" "${command[@]}")
      valued=$("$program" "${command[@]}" --help 2>/dev/null | _dembuf_valued_options)
    fi
    previous=$word
  done
  local words
  # The values an option takes, from the program itself (dembuf scene --list).
  local last=${COMP_WORDS[COMP_CWORD-1]}
  case "$last" in
    --preset | --accuracy | --format | --list)
      local what=${last#--}
      case "$what" in preset) what=presets ;; accuracy) what=accuracies ;; format) what=formats ;;
                      list) what="" ;; esac
      if [ -z "$what" ]; then
        words="fields presets accuracies formats"
      else
        words=$("$program" scene --list "$what" 2>/dev/null | cut -f1)
      fi
      mapfile -t COMPREPLY < <(compgen -W "$words" -- "$current")
      return 0
      ;;
    --set | --vary)
      # A field's dotted name, then its value after "=": no space after the name.
      words=$("$program" scene --list fields 2>/dev/null | cut -f1 | sed 's/$/=/')
      compopt -o nospace 2> /dev/null
      mapfile -t COMPREPLY < <(compgen -W "$words" -- "$current")
      return 0
      ;;
  esac
  if [[ $current == -* ]]; then
    words=$("$program" "${command[@]}" --help 2>/dev/null | _dembuf_options)
  elif [ -n "$commands" ]; then
    words=$commands  # the commands, or the subcommands of the command given
  else
    return 0  # scene files, folders, ids: bash's own completion (-o default)
  fi
  mapfile -t COMPREPLY < <(compgen -W "$words" -- "$current")
}
complete -o default -F _dembuf dembuf dembufd
