#pragma once
// The dashboard's files (api/dashboard/*.html, *.js, *.css, *.svg, and the third-party modules under
// vendor/), embedded at build time by api/embed_dashboard.cmake, served by api/static_assets.hpp.

#include <span>
#include <string_view>

namespace gw::api {

struct embedded_file {
    std::string_view name;    // "app.js", "vendor/uplot.min.js": the path under /dashboard/
    std::string_view sha256;  // hex SHA-256 of `data`, computed at build time
    std::string_view data;
    std::string_view gzip;  // `data` gzip-compressed; empty when that would not save a tenth
};

// Sorted by name.
std::span<const embedded_file> dashboard_files();

}  // namespace gw::api
