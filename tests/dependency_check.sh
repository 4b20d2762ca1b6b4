#!/usr/bin/env bash
# The layers' rule, checked on the sources. engine/core includes nothing of engine/study, the
# daemon or the client; engine/study nothing of the daemon or the client; neither needs gRPC,
# Protobuf, SQLite or a TOML parser in core, nor OpenSSL (which engine/study uses for SHA-256
# and base64). engine/study, server/ and client/ are each built of rooms: a room includes only
# itself and the rooms below it (the order of the lists below), the daemon and the client
# include nothing of each other, every source lives in a room (a program's main.cpp apart), and
# no file includes itself through others (no include cycle, which tsort finds).
# Usage: dependency_check.sh SOURCE_DIR
set -eu
root=$1
status=0

# The rooms, lowest first: a room may include itself and those before it.
study_rooms=(text spawn scene bed impact files run sweep)
# The daemon: the database and the files it owns; who may do what; the executors and what a
# running job records; the gRPC service and the web pages; main's arguments, config, serving.
server_rooms=(store access jobs notify doors process)
# The client: what the terminal shows; the commands that need the engine alone; the remote ones.
client_rooms=(terminal local remote)

alternatives() { local IFS='|'; echo "$*"; }
server_any=$(alternatives "${server_rooms[@]}")
client_any=$(alternatives "${client_rooms[@]}")

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
# A header of the daemon or the client, by its room.
own="($server_any|$client_any)/"

forbidden engine/core "dembuf/study/" "includes engine/study"
forbidden engine/core "toml|nlohmann/" "parses files (that is engine/study's work)"
forbidden engine/core "$service" "needs the service's libraries"
forbidden engine/core "$own" "includes a header of server/ or client/"
# OpenSSL's libcrypto is no service library to engine/study: its SHA-256 and base64 serve the
# results' provenance and VTK files of local runs too. The core needs it not.
forbidden engine/core "openssl/" "needs OpenSSL"
forbidden engine/study "${service%|openssl/}" "needs the service's libraries"
forbidden engine/study "$own" "includes a header of server/ or client/"
# A relative include would pass every rule below unseen: headers are named from their root.
for folder in engine/core engine/study server client; do
  forbidden "$folder" '\.\.?/' "includes by a relative path (name a header from its room)"
done
forbidden server "($client_any)/" "includes a header of the client"
forbidden client "($server_any)/" "includes a header of the daemon"

# rooms_in_order LABEL INCLUDE_PREFIX FOLDER_TEMPLATE... -- ROOM...: in each room's folders (a
# template with ROOM for the room's name), no include of a room above it.
rooms_in_order() {
  local label=$1 prefix=$2 templates=() rooms index room higher folder template
  shift 2
  while [ "$1" != "--" ]; do templates+=("$1"); shift; done
  shift
  rooms=("$@")
  for index in "${!rooms[@]}"; do
    room=${rooms[$index]}
    higher=$(alternatives "${rooms[@]:$((index + 1))}")
    for template in "${templates[@]}"; do
      folder=${template//ROOM/$room}
      [ -d "$root/$folder" ] || { echo "FAIL: $folder ($label's room $room) is missing"; status=1; continue; }
      [ -n "$higher" ] && forbidden "$folder" "$prefix($higher)/" "(room $room) includes a room above it"
    done
  done
  return 0
}

# strays LABEL DIR ALLOWED FILES_REGEX: sources of DIR whose path (from DIR) is not in a room
# (FILES_REGEX) nor ALLOWED.
strays() {
  local label=$1 dir=$2 allowed=$3 pattern=$4 found
  found=$(cd "$root/$dir" && find . -type f \( -name '*.h' -o -name '*.cpp' \) | sed 's|^\./||' |
            grep -vxE "$pattern" | grep -vxE "$allowed" | sort || true)
  if [ -n "$found" ]; then
    echo "FAIL: files of $label outside its rooms:"
    echo "$found" | sed "s|^|  $dir/|"
    status=1
  fi
}

# include_cycles LABEL DIR FILE_PREFIX INCLUDE_PREFIX ROOMS: files of DIR as nodes (ROOM/NAME: a
# header and its source are one node, a file in a room's subfolder a node of its room), "a
# includes b" as edges; tsort names a loop when the includes go round.
include_cycles() {
  local label=$1 dir=$2 file_prefix=$3 prefix=$4 rooms=$5 edges loop
  edges=$(cd "$root/$dir" && grep -rHoE --include='*.h' --include='*.cpp' \
            "^[[:space:]]*#[[:space:]]*include[[:space:]]*\"$prefix($rooms)/([a-z_]+/)*[a-z_0-9]+\.h\"" . |
          sed -E "s#^\./$file_prefix##" |
          sed -nE "s#^([a-z_]+)/([a-z_]+/)*([a-z_0-9]+)\.(h|cpp):.*\"$prefix([a-z_]+)/([a-z_]+/)*([a-z_0-9]+)\.h\"#\1/\3 \5/\7#p" |
          awk '$1 != $2' | sort -u)
  if ! loop=$(echo "$edges" | tsort 2>&1 >/dev/null) || [ -n "$loop" ]; then
    echo "FAIL: an include cycle inside $label:"
    echo "$loop" | grep -v 'input contains a loop' | sed 's/^tsort: /  /'
    status=1
  fi
}

study=engine/study
rooms_in_order engine/study dembuf/study/ "$study/include/dembuf/study/ROOM" "$study/src/ROOM" \
  -- "${study_rooms[@]}"
rooms_in_order server "" "server/ROOM" -- "${server_rooms[@]}"
rooms_in_order client "" "client/ROOM" -- "${client_rooms[@]}"

study_any=$(alternatives "${study_rooms[@]}")
# (the generated version.h apart)
strays engine/study "$study" "include/dembuf/study/version\.h" \
  "(include/dembuf/study|src)/($study_any)/.+"
strays server server "main\.cpp" "($server_any)/.+"
strays client client "main\.cpp" "($client_any)/.+"

include_cycles engine/study "$study" "(include/dembuf/study/|src/)" dembuf/study/ "$study_any"
include_cycles server server "" "" "$server_any"
include_cycles client client "" "" "$client_any"

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
[ "$status" = 0 ] && echo "layers: engine/core and engine/study include and link nothing above them; the rooms of engine/study, server/ and client/ in order, without cycles"
exit "$status"
