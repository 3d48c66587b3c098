#pragma once
// The dashboard's static files over HTTP, public (the page holds no data; every request it makes is
// authorized like any other client's):
//   GET|HEAD /                    index.html
//   GET|HEAD /dashboard/<file>    the page's modules, style sheet and images; vendor/<file> for the
//                                 third-party modules (uPlot, js-yaml, MQTT.js)
//   GET|HEAD /dashboard[/]        301 to /, where the page is
// Content-Type by extension, gzip (built at build time) for clients that accept it, a strong ETag
// per representation (the build-time SHA-256 of the content) answered with 304 on a matching
// If-None-Match, Cache-Control: no-cache (revalidate every time: the names are not
// versioned), and a Content-Security-Policy that allows only this origin and no inline script or
// style. Other methods: 405 problem+json with Allow; an unknown file: 404 problem+json.

#include <string>
#include <string_view>

#include "api/common/response_headers.hpp"

namespace gw::api {

// True for "/", "/dashboard" and everything under "/dashboard/".
bool is_static_asset_path(std::string_view path);

// The route template for metrics: "/", "/dashboard/" (the redirect) or "/dashboard/{file}".
std::string static_asset_route(std::string_view path);

string_response static_asset_response(const string_request& request, const std::string& request_id);

}  // namespace gw::api
