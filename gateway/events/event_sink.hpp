#pragma once
// The receiving end of an event hub subscriber: a WebSocket session, the MQTT bridge, a test.
// Both callbacks run on the hub's strand: never block, never call back into the hub synchronously
// expecting an answer; post to your own strand and return.
//
// Flow control is credit-based so "one write in flight" is natural for a WebSocket session:
//   1. the hub calls deliver(batch) once; it delivers nothing more to this sink until...
//   2. ...the sink has written the whole batch (one frame at a time, one write in flight) and calls
//      event_hub::request_more(id). The hub then delivers what queued up meanwhile, or waits for the
//      next event.
// A WebSocket session, sketched:
//   deliver(batch): post to the session strand; outbox = batch; write(outbox.front()->message)
//   on_write:       pop the front; write the next one, or hub->request_more(id) when outbox is empty
//   close(reason):  post; async_close({websocket::close_code::policy_error, reason})
// so the session's own queue never holds more than one batch.
// Everything that arrives between 1 and 2 waits in the hub, in a bounded per-subscriber queue (see
// event_hub.hpp for the overflow policy). The hub holds sinks by weak_ptr: a sink that is destroyed
// is forgotten; remove_subscriber() is still the polite way out.

#include <memory>
#include <string>
#include <vector>

#include "gateway/events/event.hpp"

namespace gw {

class event_sink {
  public:
    virtual ~event_sink() = default;

    // Events in order (per topic: increasing sequence numbers, gap events where some are missing).
    // Never empty. At most subscriber_settings::max_batch_events stream/gap events plus one event per
    // latest-value topic.
    virtual void deliver(std::vector<std::shared_ptr<const event>> batch) = 0;

    // The hub dropped this subscriber ("too slow: ...", "event hub stopped"); nothing follows. A
    // WebSocket session sends a close frame with this reason (policy violation / going away).
    virtual void close(std::string reason) = 0;
};

}  // namespace gw
