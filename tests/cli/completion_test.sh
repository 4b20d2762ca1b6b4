#!/usr/bin/env bash
# The bash completion (deploy/dembuf-completion.bash) completes commands and options from the
# binaries' --help, and the manual pages (deploy/man.sh) are made from it and render.
# Usage: completion_test.sh DEMBUF DEMBUFD SOURCE_DIR
set -eu
dembuf=$1
dembufd=$2
src=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# shellcheck source=/dev/null
. "$src/deploy/dembuf-completion.bash"
# complete WORDS...: what Tab offers after the words (the last one is being typed).
complete_words() {
  COMP_WORDS=("$@")
  COMP_CWORD=$((${#COMP_WORDS[@]} - 1))
  COMPREPLY=()
  _dembuf
  printf '%s\n' "${COMPREPLY[@]}"
}
[ "$(complete_words "$dembuf" ru)" = run ] || fail "dembuf ru<Tab>: $(complete_words "$dembuf" ru)"
complete_words "$dembuf" s | grep -qx sweep || fail "dembuf s<Tab> lacks sweep"
complete_words "$dembuf" s | grep -qx server-info || fail "dembuf s<Tab> lacks server-info"
complete_words "$dembuf" run --o | grep -qx -- --out || fail "dembuf run --o<Tab> lacks --out"
complete_words "$dembuf" run --j | grep -qx -- --json || fail "dembuf run --j<Tab> lacks --json"
# An option's value before the command is not taken for the command.
complete_words "$dembuf" --server run list --st | grep -qx -- --state ||
  fail "dembuf --server run list --st<Tab> lacks --state"
if complete_words "$dembuf" list --st | grep -qx -- --out; then fail "list offers run's --out"; fi
complete_words "$dembufd" --ht | grep -qx -- --http || fail "dembufd --ht<Tab> lacks --http"
complete_words "$dembufd" token | grep -qx token-create || fail "dembufd token<Tab>"
# A command's aliases are commands ("bed, beds" offered "bed,"), and a command's subcommands
# follow it (dembuf bed <Tab> offered the top-level commands), with their own options.
[ "$(complete_words "$dembuf" be | tr '\n' ' ')" = "bed beds " ] ||
  fail "dembuf be<Tab>: $(complete_words "$dembuf" be | tr '\n' ' ')"
[ "$(complete_words "$dembuf" bed "" | tr '\n' ' ')" = "export push " ] ||
  fail "dembuf bed <Tab>: $(complete_words "$dembuf" bed "" | tr '\n' ' ')"
complete_words "$dembuf" beds export --fo | grep -qx -- --format ||
  fail "dembuf beds export --fo<Tab> lacks --format"
# The values: presets, accuracies, formats and scene fields (they completed nothing).
[ "$(complete_words "$dembuf" run --preset e | tr '\n' ' ')" = "e1 e2 e2-heavy-beads e2-local-damping e2-steel-mix e2-steel-under-glass e2-viscous-damping e3 e4 e5 " ] ||
  fail "dembuf run --preset e<Tab>: $(complete_words "$dembuf" run --preset e)"
complete_words "$dembuf" run --accuracy "" | grep -qx draft || fail "--accuracy <Tab> lacks draft"
complete_words "$dembuf" bed export --format "" | grep -qx lammps || fail "--format <Tab> lacks lammps"
complete_words "$dembuf" run --set bed.th | grep -qx "bed.thickness_m=" ||
  fail "dembuf run --set bed.th<Tab>: $(complete_words "$dembuf" run --set bed.th)"
complete_words "$dembuf" sweep --vary projectile.sp | grep -qx "projectile.speed_m_s=" ||
  fail "dembuf sweep --vary projectile.sp<Tab>"

# The manual pages: one per program, every command's options in dembuf's.
bash "$src/deploy/man.sh" "$dembuf" "$dembufd" "$work/man" > /dev/null
for page in dembuf dembufd; do
  [ -s "$work/man/$page.1" ] || fail "no $page.1"
  MANWIDTH=100 man -l "$work/man/$page.1" > "$work/$page.txt" 2> "$work/$page.err" ||
    fail "$page.1 does not render: $(cat "$work/$page.err")"
done
for text in "--find-hc" "--json" "DEMBUF_PROGRESS_S" "SIGTERM" "Usage: dembuf run" "EXAMPLES" \
  "SCENE FIELDS" "bed.thickness_m" "[m] [0 to 10]: settled bed thickness H" "PRESETS" "e2-steel-mix" \
  "Bed formats (bed export --format): text lammps vtp"; do
  grep -qF -- "$text" "$work/dembuf.txt" || fail "dembuf.1 lacks $text"
done
grep -qF -- "token-create" "$work/dembufd.txt" || fail "dembufd.1 lacks token-create"
echo "completion: commands and options from --help; manual pages render"
