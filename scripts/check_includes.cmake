# The layering check of one library (CMakeLists.txt: gw_check_layering): every project include in its
# files must point into a folder the library may use. Run with cmake -P; fails the build with the
# file, the line and the include that breaks the layering.
#   -DFILES=a.cpp|b.hpp  -DALLOWED=devices/|gateway/  -DEXCEPT=gateway/jobs/  -DLIBRARY=gw_core  -DSTAMP=out
string(REPLACE "|" ";" files "${FILES}")
string(REPLACE "|" ";" allowed "${ALLOWED}")
string(REPLACE "|" ";" except "${EXCEPT}")
# Only the project's own folders: system and package headers are not layers.
set(layers "devices/" "gateway/" "api/")

# Sets `result` to TRUE when `path` starts with one of the `prefixes`.
function(starts_with_any path prefixes result)
  set(found FALSE)
  foreach(prefix IN LISTS prefixes)
    string(FIND "${path}" "${prefix}" at)
    if(at EQUAL 0)
      set(found TRUE)
    endif()
  endforeach()
  set(${result} ${found} PARENT_SCOPE)
endfunction()

set(problems "")
foreach(file IN LISTS files)
  file(STRINGS "${file}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
  foreach(line IN LISTS lines)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*\"([^\"]*)\".*" "\\1" included "${line}")
    starts_with_any("${included}" "${layers}" in_project)
    if(NOT in_project)
      continue()
    endif()
    starts_with_any("${included}" "${allowed}" is_allowed)
    starts_with_any("${included}" "${except}" is_excepted)
    if(NOT is_allowed OR is_excepted)
      string(APPEND problems "\n  ${file}: #include \"${included}\"")
    endif()
  endforeach()
endforeach()
if(problems)
  list(JOIN allowed ", " allowed_text)
  set(except_text "")
  if(except)
    list(JOIN except ", " except_text)
    set(except_text " (but not ${except_text})")
  endif()
  message(FATAL_ERROR "${LIBRARY} may include only ${allowed_text}${except_text}; these point elsewhere (against the "
                      "layering api -> gateway -> devices):${problems}")
endif()
file(WRITE "${STAMP}" "")
