#pragma once
// openapi/openapi.yaml, embedded at build time (api/embed_openapi.cmake), served at
// GET /api/v1/openapi.yaml.

#include <string_view>

namespace gw::api {

std::string_view openapi_document();

}  // namespace gw::api
