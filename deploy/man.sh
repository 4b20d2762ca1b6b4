#!/usr/bin/env bash
# Makes the manual pages dembuf.1 and dembufd.1 from the programs' own --help (help2man), with
# every command's help in a COMMANDS section, so that they say what the binaries do.
# Usage: deploy/man.sh DEMBUF DEMBUFD OUT_DIR   (then: man -l OUT_DIR/dembuf.1, or copy the
# pages to /usr/local/share/man/man1)
set -euo pipefail
dembuf=$1
dembufd=$2
out=$3
command -v help2man > /dev/null || bash "$(dirname "$0")/install-deps.sh" help2man
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# A help text as preformatted troff: backslashes, and dots or quotes that start a line, escaped.
as_troff() {
  echo ".nf"
  sed -e 's/\\/\\e/g' -e "s/^\([.']\)/\\\\\&\1/"
  echo ".fi"
}
# The commands of a program: the first words of the lines under "Subcommands:".
commands_of() {
  "$1" --help | awk '/^Subcommands:/ { in_list = 1; next }
                     in_list && /^  [a-z]/ { print $1 }
                     in_list && /^$/ { in_list = 0 }'
}

describe() {
  local program=$1 name=$2 summary=$3 environment=$4
  {
    echo "[COMMANDS]"
    for command in $(commands_of "$program"); do
      echo ".SS $command"
      # (Usage lines name the program as it was called: by its name here, not its path.)
      "$program" "$command" --help | tail -n +2 | sed "s|$program |$name |" | as_troff
    done
    echo "[ENVIRONMENT]"
    echo "$environment"
    echo "[SEE ALSO]"
    echo "README.md and docs/ of the dembuf sources: the model, the service, accuracy and speed."
  } > "$work/$name.h2m"
  help2man --no-info --name "$summary" --include "$work/$name.h2m" --output "$out/$name.1" \
    "$program"
}

describe "$dembuf" dembuf "DEM simulation of impacts on granular buffer layers" '.TP
.B DEMBUF_SERVER
the dembufd address host:port when --server is not given (default 127.0.0.1:50051)
.TP
.B DEMBUF_TOKEN
the API token of a server that needs one
.TP
.B DEMBUF_TLS_CA
a PEM certificate to trust: speak TLS to the server
.TP
.B DEMBUF_BED_CACHE
the folder of prepared beds (default ~/.cache/dembuf/beds)
.TP
.B DEMBUF_PROGRESS_S
seconds between progress lines when stderr is not a terminal (default 5; 1 with -v)
.TP
.B OMP_NUM_THREADS
threads of a local run (default: every core)'
describe "$dembufd" dembufd "the dembuf daemon: gRPC API, job queue, SQLite store, web pages" \
  'None: dembufd is set by its flags and its configuration file (--config; deploy/dembufd.toml
of the sources describes every setting).'
echo "wrote $out/dembuf.1 and $out/dembufd.1"
