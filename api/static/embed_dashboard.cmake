# cmake -DINPUT_DIR=api/dashboard -DVENDOR="vendor/x.js=/path/x.js|..." -DOUTPUT=dashboard_files.cpp
#       -P embed_dashboard.cmake
# Embeds the dashboard's top-level *.html, *.js, *.css and *.svg files (not screenshots/ or
# node_modules/), and the third-party files named in VENDOR under the names given there, as byte
# arrays. Each file carries the SHA-256 of its content (the strong ETag the gateway sends) and, when
# gzip saves at least a tenth, its gzip-compressed bytes (sent to clients that accept gzip).
file(GLOB files RELATIVE ${INPUT_DIR} ${INPUT_DIR}/*.html ${INPUT_DIR}/*.js ${INPUT_DIR}/*.css
     ${INPUT_DIR}/*.svg)
set(entries "")
foreach(name IN LISTS files)
  list(APPEND entries "${name}=${INPUT_DIR}/${name}")
endforeach()
string(REPLACE "|" ";" vendor "${VENDOR}")
list(APPEND entries ${vendor})
list(SORT entries)

get_filename_component(work_dir ${OUTPUT} DIRECTORY)
set(gzip_dir ${work_dir}/dashboard_gzip)
file(REMOVE_RECURSE ${gzip_dir})
file(MAKE_DIRECTORY ${gzip_dir})

# The file's bytes as a C array initialiser, and its size.
function(byte_array path out_bytes out_size)
  file(READ ${path} hex HEX)
  string(LENGTH "${hex}" hex_length)
  math(EXPR size "${hex_length} / 2")
  string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
  set(${out_bytes} "${bytes}" PARENT_SCOPE)
  set(${out_size} ${size} PARENT_SCOPE)
endfunction()

set(arrays "")
set(table "")
set(i 0)
foreach(entry IN LISTS entries)
  string(FIND "${entry}" "=" eq)
  string(SUBSTRING "${entry}" 0 ${eq} name)
  math(EXPR from "${eq} + 1")
  string(SUBSTRING "${entry}" ${from} -1 path)
  if(NOT EXISTS ${path})
    message(FATAL_ERROR "dashboard file ${path} is missing: run scripts/install-deps (npm ci in api/dashboard)")
  endif()
  file(SHA256 ${path} sha)
  byte_array(${path} bytes size)
  string(APPEND arrays "const unsigned char file${i}[${size} + 1] = {${bytes} 0};\n")

  # gzip through CMake's own libarchive: no build tool beyond CMake.
  set(gz ${gzip_dir}/file${i}.gz)
  file(COPY_FILE ${path} ${gzip_dir}/file${i})
  file(ARCHIVE_CREATE OUTPUT ${gz} PATHS ${gzip_dir}/file${i} FORMAT raw COMPRESSION GZip
       COMPRESSION_LEVEL 9)
  byte_array(${gz} gz_bytes gz_size)
  math(EXPR gz_tenfold "${gz_size} * 10")
  math(EXPR size_ninefold "${size} * 9")
  if(gz_tenfold LESS_EQUAL size_ninefold)
    string(APPEND arrays "const unsigned char gzip${i}[${gz_size} + 1] = {${gz_bytes} 0};\n")
    set(gzip_view "{reinterpret_cast<const char*>(gzip${i}), ${gz_size}}")
  else()
    set(gzip_view "{}")
  endif()
  string(APPEND table "    {\"${name}\", \"${sha}\", {reinterpret_cast<const char*>(file${i}), ${size}}, "
                      "${gzip_view}},\n")
  math(EXPR i "${i} + 1")
endforeach()
file(REMOVE_RECURSE ${gzip_dir})

file(WRITE ${OUTPUT}.tmp
  "// Generated from api/dashboard/ by api/static/embed_dashboard.cmake. Do not edit.\n"
  "#include \"api/static/dashboard_files.hpp\"\n\n"
  "namespace gw::api {\n\n"
  "namespace {\n"
  "${arrays}"
  "const embedded_file table[] = {\n${table}};\n"
  "}  // namespace\n\n"
  "std::span<const embedded_file> dashboard_files() {\n"
  "    return table;\n"
  "}\n\n"
  "}  // namespace gw::api\n")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
file(REMOVE ${OUTPUT}.tmp)
