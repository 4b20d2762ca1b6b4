#!/usr/bin/env bash
# The layers' rule, checked on the sources: engine/core includes nothing of engine/study, the
# service or the client; engine/study nothing of the service or the client; neither needs
# gRPC, Protobuf, SQLite or a TOML parser in core, nor OpenSSL (which engine/study uses for
# SHA-256 and base64).
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
[ "$status" = 0 ] && echo "layers: engine/core and engine/study include and link nothing above them"
exit "$status"
