# cmake -DINPUT_DIR=api/dashboard -DOUTPUT=dashboard_files.cpp -P embed_dashboard.cmake
# Embeds the dashboard's top-level *.html, *.js, *.css and *.svg files (not screenshots/) as byte
# arrays, each with the SHA-256 of its content (the strong ETag the gateway sends).
file(GLOB files RELATIVE ${INPUT_DIR} ${INPUT_DIR}/*.html ${INPUT_DIR}/*.js ${INPUT_DIR}/*.css
     ${INPUT_DIR}/*.svg)
list(SORT files)
set(arrays "")
set(table "")
set(i 0)
foreach(name IN LISTS files)
  file(READ ${INPUT_DIR}/${name} hex HEX)
  file(SHA256 ${INPUT_DIR}/${name} sha)
  string(LENGTH "${hex}" hex_length)
  math(EXPR size "${hex_length} / 2")
  string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
  string(APPEND arrays "const unsigned char file${i}[${size} + 1] = {${bytes} 0};\n")
  string(APPEND table "    {\"${name}\", \"${sha}\", {reinterpret_cast<const char*>(file${i}), ${size}}},\n")
  math(EXPR i "${i} + 1")
endforeach()
file(WRITE ${OUTPUT}.tmp
  "// Generated from api/dashboard/ by api/embed_dashboard.cmake. Do not edit.\n"
  "#include \"api/dashboard_files.hpp\"\n\n"
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
