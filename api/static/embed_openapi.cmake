# cmake -DINPUT=openapi.yaml -DOUTPUT=openapi_document.cpp -P embed_openapi.cmake
# Writes the document as a byte array (no raw-string delimiter can clash with its text).
file(READ ${INPUT} hex HEX)
string(LENGTH "${hex}" hex_length)
math(EXPR size "${hex_length} / 2")
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
file(WRITE ${OUTPUT}
  "// Generated from openapi/openapi.yaml by api/static/embed_openapi.cmake. Do not edit.\n"
  "#include \"api/static/openapi_document.hpp\"\n\n"
  "namespace gw::api {\n\n"
  "namespace {\n"
  "const unsigned char document[${size} + 1] = {${bytes} 0};\n"
  "}  // namespace\n\n"
  "std::string_view openapi_document() {\n"
  "    return {reinterpret_cast<const char*>(document), ${size}};\n"
  "}\n\n"
  "}  // namespace gw::api\n")
