#pragma once
// A response body made piece by piece, for downloads larger than memory should hold (a recording's
// frames): the HTTP session writes the response header with chunked transfer encoding, then asks for
// one piece at a time and writes it as a chunk before asking for the next, so only one piece is held
// per connection. A body that fails after the header cannot change the status any more: the session
// closes the connection without the last chunk, and the client sees an incomplete response, never a
// short one that looks whole.

#include <functional>
#include <optional>
#include <string>

namespace gw::api {

class streamed_body {
  public:
    // `piece`: the next bytes (empty only with `last`); nullopt: the body failed. Called once per
    // next(), from any thread.
    using piece_handler = std::function<void(std::optional<std::string> piece, bool last)>;

    virtual ~streamed_body() = default;
    // Asked again only after the handler of the call before ran with `last` false.
    virtual void next(piece_handler h) = 0;
};

}  // namespace gw::api
