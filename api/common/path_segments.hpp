#pragma once
// The one way the API splits a URL path: "/api/v1/jobs/j-1" -> {"api", "v1", "jobs", "j-1"}. Empty
// segments are kept ("/a//b" -> {"a", "", "b"}, "/a/" -> {"a", ""}), so a route never matches a path
// with a doubled or trailing slash. The views point into `path`.

#include <string_view>
#include <vector>

namespace gw::api {

std::vector<std::string_view> path_segments(std::string_view path);

}  // namespace gw::api
