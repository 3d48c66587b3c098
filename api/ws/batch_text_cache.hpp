#pragma once
// The text of the last few WebSocket batch messages, so that sessions that get the same events in the
// same window (their windows share a grid: websocket_session::request_next_batch) send the same bytes
// instead of each building a copy. With 100 clients of 32 busy report streams, building the batch
// text per client was one copy of every event per client.
//
// Thread safety: any session's strand may call text().

#include <array>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "gateway/events/event.hpp"

namespace gw::api {

class batch_text_cache {
  public:
    // ws_batch_message(events), built once for the same events in the same order.
    std::shared_ptr<const std::string> text(const std::vector<std::shared_ptr<const event>>& events);

  private:
    struct entry {
        // Held, not only compared by address: a freed event's address could come back as another's.
        std::vector<std::shared_ptr<const event>> events;
        std::shared_ptr<const std::string> text;
    };
    static constexpr std::size_t slots = 4;  // windows overlap a little: a few recent batches suffice

    std::mutex mutex_;
    std::array<entry, slots> recent_;
    std::size_t next_slot_ = 0;
};

}  // namespace gw::api
