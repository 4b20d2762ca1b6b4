#!/usr/bin/env bash
# The function-length check can fail: on a planted source tree it must refuse a function of
# 101 lines (in a namespace, a member defined in its class, a template), pass one of 100, and refuse an
# exception whose function has become short. Braces in strings, comments and character
# literals must not count.
# Usage: function_length_planted.sh SOURCE_DIR
set -eu
root=$1
check=$root/tests/function_length.py
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# function NAME LINES: a function of that many lines, from its '{' to its '}'.
function_of() {
  echo "int $1(int x) {"
  for _ in $(seq $(($2 - 3))); do echo '  x += 1;  // } { "}" '"'}'"; done
  echo "  return x;"
  echo "}"
}
mkdir -p "$work/engine" "$work/server" "$work/client"
{ echo "namespace a {"; function_of Short 100; echo "}  // namespace a"; } > "$work/engine/short.cpp"
python3 "$check" "$work" > "$work/out" || fail "a function of 100 lines was refused: $(cat "$work/out")"

{ echo 'const char* s = "{{{";'; function_of Long 102; } > "$work/server/long.cpp"
if python3 "$check" "$work" > "$work/out"; then fail "a function of 102 lines passed"; fi
grep -q "server/long.cpp:2 Long: 102 lines" "$work/out" || fail "not named: $(cat "$work/out")"
rm "$work/server/long.cpp"

{ echo "class Routes {"; echo " public:"; function_of Member 101 | sed 's/^int /  int /'; echo "};"; } \
  > "$work/client/member.h"
if python3 "$check" "$work" > "$work/out"; then fail "a member of 101 lines passed"; fi
grep -q "client/member.h:3 Member: 101 lines" "$work/out" || fail "not named: $(cat "$work/out")"
rm "$work/client/member.h"

# A template of `class` parameters is a function too (its `class` was taken for a scope).
{ echo "template <class E, typename F>"; function_of Templated 101; } > "$work/engine/templated.cpp"
if python3 "$check" "$work" > "$work/out"; then fail "a template function of 101 lines passed"; fi
grep -q "engine/templated.cpp:2 Templated: 101 lines" "$work/out" || fail "not named: $(cat "$work/out")"
rm "$work/engine/templated.cpp"

# An exception that no longer holds is refused too: the copy of the tree has the named
# functions short.
mkdir -p "$work/engine/core/src"
function_of RebuildPairList 20 > "$work/engine/core/src/neighbor_list.cpp"
if python3 "$check" "$work" > "$work/out"; then fail "a stale exception passed"; fi
grep -q "the exception engine/core/src/neighbor_list.cpp RebuildPairList is no longer over" "$work/out" ||
  fail "stale exception not named: $(cat "$work/out")"
echo "function length: a planted long function, member and template, and a stale exception, are refused"
