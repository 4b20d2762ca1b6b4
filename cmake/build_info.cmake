# Run at every build (cmake -P): writes OUT, the build's commit and type, when they changed, so
# that a result names the code that made it without rebuilding what did not change.
# Arguments: SOURCE_DIR, OUT, BUILD_TYPE.
set(commit "unknown")
execute_process(COMMAND git -C "${SOURCE_DIR}" rev-parse HEAD
                OUTPUT_VARIABLE head RESULT_VARIABLE failed ERROR_QUIET
                OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT failed AND head MATCHES "^[0-9a-f]+$")
  set(commit "${head}")
  # Changes to the tree make the commit an approximation: say so, with a hash of the changes
  # (the diff, and the new files' names and bytes), so that two builds of different changes
  # never name the same code (a daemon reuses a result only of the same code: issue "never
  # the same run twice").
  execute_process(COMMAND git -C "${SOURCE_DIR}" status --porcelain --untracked-files=no
                  OUTPUT_VARIABLE changes ERROR_QUIET)
  execute_process(COMMAND git -C "${SOURCE_DIR}" ls-files --others --exclude-standard
                  OUTPUT_VARIABLE untracked ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT changes STREQUAL "" OR NOT untracked STREQUAL "")
    execute_process(COMMAND git -C "${SOURCE_DIR}" diff HEAD OUTPUT_VARIABLE diff ERROR_QUIET)
    string(REPLACE "\n" ";" untracked "${untracked}")
    foreach(file IN LISTS untracked)
      if(EXISTS "${SOURCE_DIR}/${file}" AND NOT IS_DIRECTORY "${SOURCE_DIR}/${file}")
        file(SHA256 "${SOURCE_DIR}/${file}" file_hash)
        string(APPEND diff "${file} ${file_hash}\n")
      endif()
    endforeach()
    string(SHA256 diff_hash "${diff}")
    string(SUBSTRING "${diff_hash}" 0 12 diff_hash)
    string(APPEND commit "-dirty-${diff_hash}")
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
