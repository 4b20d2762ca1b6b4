# Run at every build (cmake -P): writes OUT, the build's commit and type, when they changed, so
# that a result names the code that made it without rebuilding what did not change.
# Arguments: SOURCE_DIR, OUT, BUILD_TYPE.
set(commit "unknown")
execute_process(COMMAND git -C "${SOURCE_DIR}" rev-parse HEAD
                OUTPUT_VARIABLE head RESULT_VARIABLE failed ERROR_QUIET
                OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT failed AND head MATCHES "^[0-9a-f]+$")
  set(commit "${head}")
  # Changes to tracked files make the commit an approximation: say so.
  execute_process(COMMAND git -C "${SOURCE_DIR}" status --porcelain --untracked-files=no
                  OUTPUT_VARIABLE changes ERROR_QUIET)
  if(NOT changes STREQUAL "")
    string(APPEND commit "-dirty")
  endif()
endif()
set(text "// Generated at build time by cmake/build_info.cmake.
#include \"dembuf/study/files/provenance.h\"

namespace dembuf::report {
const char* BuildCommit() { return \"${commit}\"; }
const char* BuildType() { return \"${BUILD_TYPE}\"; }
}  // namespace dembuf::report
")
set(old "")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
endif()
if(NOT old STREQUAL text)
  file(WRITE "${OUT}" "${text}")
endif()
