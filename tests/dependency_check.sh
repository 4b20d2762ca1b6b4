#!/usr/bin/env bash
# The layers' rule, checked on the sources: engine/core includes nothing of engine/study, the
# service or the client; engine/study nothing of the service or the client; neither needs
# gRPC, Protobuf, SQLite or a TOML parser in core, nor OpenSSL (which engine/study uses for
# SHA-256 and base64). Inside engine/study, each room includes only itself and the rooms below
# it (the order of `rooms` below), and no file of study includes itself through others (no
# include cycle, which tsort finds).
# Usage: dependency_check.sh SOURCE_DIR
set -eu
root=$1
status=0

# forbidden FOLDER PATTERN WHY: every #include in FOLDER matching PATTERN is a violation.
forbidden() {
  local folder=$1 pattern=$2 why=$3 hits
  hits=$(grep -rnE --include='*.h' --include='*.cpp' --include='*.in' \
           "^[[:space:]]*#[[:space:]]*include[[:space:]]*[<\"]($pattern)" "$root/$folder" || true)
  if [ -n "$hits" ]; then
    echo "FAIL: $folder $why:"
    echo "$hits" | sed "s|$root/||"
    status=1
  fi
}

service='grpc|grpcpp/|google/protobuf|dembuf/v1/|sqlite3|spdlog/|openssl/'
# The service's and the client's own headers, by name.
own=$(cd "$root" && ls server/*.h client/*.h | xargs -n1 basename | paste -sd'|' | sed 's/\./\\./g')

forbidden engine/core "dembuf/study/" "includes engine/study"
forbidden engine/core "toml|nlohmann/" "parses files (that is engine/study's work)"
forbidden engine/core "$service" "needs the service's libraries"
forbidden engine/core "($own)\"" "includes a header of server/ or client/"
# OpenSSL's libcrypto is no service library to engine/study: its SHA-256 and base64 serve the
# results' provenance and VTK files of local runs too. The core needs it not.
forbidden engine/core "openssl/" "needs OpenSSL"
forbidden engine/study "${service%|openssl/}" "needs the service's libraries"
forbidden engine/study "($own)\"" "includes a header of server/ or client/"

# The rooms of engine/study, lowest first: a room may include itself and those before it.
rooms=(text scene bed impact files run sweep)
study=engine/study
for index in "${!rooms[@]}"; do
  room=${rooms[$index]}
  higher=$(printf '%s|' "${rooms[@]:$((index + 1))}")
  for folder in "$study/include/dembuf/study/$room" "$study/src/$room"; do
    [ -d "$root/$folder" ] || { echo "FAIL: $folder is missing"; status=1; continue; }
    [ -n "$higher" ] && forbidden "$folder" "dembuf/study/(${higher%|})/" \
      "(room $room) includes a room above it"
  done
done
# Every header and source of study lives in a room (the generated version.h apart).
strays=$(cd "$root/$study" && find include/dembuf/study src -maxdepth 1 -type f \
           \( -name '*.h' -o -name '*.cpp' \) | sort)
if [ -n "$strays" ]; then
  echo "FAIL: files of engine/study outside its rooms:"
  echo "$strays"
  status=1
fi
# Files of study as nodes, "a includes b" as edges (a header and its source are one node; a
# file in a room's subfolder is a node of its room):
# tsort names a loop when the includes go round.
edges=$(cd "$root/$study" && grep -rHoE --include='*.h' --include='*.cpp' \
          '^[[:space:]]*#[[:space:]]*include[[:space:]]*"dembuf/study/[a-z_]+/[a-z_0-9]+\.h"' \
          include src |
        sed -E 's|^(include/dembuf/study/\|src/)([a-z_]+)/([a-z_]+/)*([a-z_0-9]+)\.(h\|cpp):.*"dembuf/study/([a-z_]+/[a-z_0-9]+)\.h"|\2/\4 \6|' |
        awk '$1 != $2' | sort -u)
if ! loop=$(echo "$edges" | tsort 2>&1 >/dev/null) || [ -n "$loop" ]; then
  echo "FAIL: an include cycle inside engine/study:"
  echo "$loop" | grep -v 'input contains a loop' | sed 's/^tsort: /  /'
  status=1
fi

# The core's names live in dembuf::dem (and its detail), so that code above says where they
# come from; anonymous namespaces apart.
hits=$(grep -rnE --include='*.h' --include='*.cpp' '^[[:space:]]*namespace[[:space:]]+[A-Za-z_:]+[[:space:]]*\{' \
         "$root/engine/core" | grep -vE 'namespace (dembuf::dem(::detail)?|detail) \{' || true)
if [ -n "$hits" ]; then
  echo "FAIL: engine/core declares names outside dembuf::dem:"
  echo "$hits" | sed "s|$root/||"
  status=1
fi

# The libraries' link lines say the same.
if grep -qE 'dembuf::study|dembuf_study|toml11|gRPC|SQLite' "$root/engine/core/CMakeLists.txt"; then
  echo "FAIL: engine/core/CMakeLists.txt links something above the core"
  status=1
fi
if grep -qE 'gRPC|protobuf|SQLite|spdlog|dembuf::proto|dembuf_server|dembuf_cli' \
     "$root/engine/study/CMakeLists.txt"; then
  echo "FAIL: engine/study/CMakeLists.txt links the service or the client"
  status=1
fi
[ "$status" = 0 ] && echo "layers: engine/core and engine/study include and link nothing above them; study's rooms in order, without cycles"
exit "$status"
