#pragma once
// X-Request-Id: honoured when the client sends a sane one (1..128 printable ASCII characters, no
// spaces), otherwise created. Returned in every response, put in logs, passed to the registry so
// every serial command it causes is traced with it.

#include <string>
#include <string_view>

namespace gw::api {

inline constexpr std::size_t max_request_id_bytes = 128;

bool is_valid_request_id(std::string_view id);
// A new id: 16 lowercase hex digits, unique within the process and random across restarts.
std::string make_request_id();
// The client's id when valid, else a new one.
std::string request_id_for(std::string_view header_value);

}  // namespace gw::api
