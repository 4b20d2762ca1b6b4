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
# Lines "TERM<tab>TEXT" as a troff list of terms, each followed by its text (escaped).
as_term_list() {
  awk -F'\t' '{
    text = $2; gsub(/\\/, "\\e", text)
    if (text ~ /^[.\x27]/) text = "\\&" text
    print ".TP"; print ".B " $1; print text }'
}
# The commands of a program and their subcommands, as the completion reads them (one list).
# shellcheck source=dembuf-completion.bash
. "$(dirname "$0")/dembuf-completion.bash"
commands_of() {
  local command sub
  for command in $(_dembuf_commands "$1"); do
    # (An alias is the same command: "bed, beds" is described once.)
    "$1" --help | grep -qE "^  ([a-z-]+, )*$command(,|  )" || continue
    "$1" --help | grep -qE "^  [a-z-]+, ([a-z-]+, )*$command(,|  )" && continue
    echo "$command"
    for sub in $(_dembuf_commands "$1" "$command"); do echo "$command $sub"; done
  done
}

describe() {
  local program=$1 name=$2 summary=$3 environment=$4 extra=${5:-}
  {
    echo "[COMMANDS]"
    local command
    while read -r -a command; do
      echo ".SS ${command[*]}"
      # (Usage lines name the program as it was called: by its name here, not its path.)
      "$program" "${command[@]}" --help | tail -n +2 | sed "s|$program |$name |" | as_troff
    done < <(commands_of "$program")
    [ -z "$extra" ] || "$extra" "$program"
    echo "[ENVIRONMENT]"
    echo "$environment"
    echo "[SEE ALSO]"
    echo "README.md and docs/ of the dembuf sources: the model, the service, accuracy and speed."
  } > "$work/$name.h2m"
  help2man --no-info --name "$summary" --include "$work/$name.h2m" --output "$out/$name.1" \
    "$program"
}

# dembuf's examples, and its scene fields with units and ranges (from `dembuf scene --list`).
dembuf_sections() {
  local program=$1
  echo "[EXAMPLES]"
  as_troff <<'EXAMPLES'
dembuf run --preset e2 --set bed.thickness_m=0.02 --out runs/first
    the paper's E2 impact on a 2 cm bed; the bed is cached for the next run
dembuf run --preset e2 --set bed.thickness_m=0.02 --dry-run
    what the run would cost: beads, steps, files, memory, predicted time
dembuf sweep --preset e2 --vary bed.thickness_m=0:0.08:0.005 --seeds 3 --out runs/e2
    the paper's thickness sweep with three bed seeds; --dry-run prints its plan
dembuf compare runs/e2
    the sweep beside every number the paper gives for E2
dembuf run --set bed.import=bed.data --set bed.import_units=mm
    an impact on a bed from LAMMPS (data or dump file), written in millimetres
dembuf submit --preset e2 --set bed.thickness_m=0.04; dembuf watch 1; dembuf fetch 1
    the same on a dembufd: queue, follow live, fetch the files
EXAMPLES
  echo "[SCENE FIELDS]"
  echo "Every field of a scene file, by its dotted name as --set and --vary take it, with its"
  # (The stages' names come from the program's own list, in the order it first gives them.)
  echo "unit, its allowed range (or values), its meaning and the earliest stage of a run it enters"
  echo "(every cut: also the cuts between a bed's layers; output: only what a run writes):"
  echo "$("$program" scene --list fields | awk -F'\t' '!seen[$5]++ { print $5 }' | paste -sd, - | sed 's/,/, /g')."
  # (awk, not read: a field without a unit or a range has empty columns between its tabs.)
  "$program" scene --list fields |
    awk -F'\t' '{ print $1 "\t" ($2 != "" ? "[" $2 "] " : "") ($3 != "" ? $3 ": " : "") $4 "; shapes: " $5 }' |
    as_term_list
  echo ".PP"
  echo "Accuracies (--accuracy): $("$program" scene --list accuracies | cut -f1 | tr '\n' ' ')"
  echo ".br"
  echo "Bed formats (bed export --format): $("$program" scene --list formats | cut -f1 | tr '\n' ' ')"
  echo "[PRESETS]"
  echo "The scenes --preset starts from (scenes/*.toml of the sources), each with its first sentence."
  "$program" scene --list presets | as_term_list
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
threads of a local run (default: every core)' dembuf_sections
describe "$dembufd" dembufd "the dembuf daemon: gRPC API, job queue, SQLite store, web pages" \
  'None: dembufd is set by its flags and its configuration file (--config; deploy/dembufd.toml
of the sources describes every setting).'
echo "wrote $out/dembuf.1 and $out/dembufd.1"
