#pragma once
// The newest state JSON of each controller, as text: built once per snapshot by the events bridge
// (the very text that "controllers/<id>/state" events carry), so that GET /api/v1/controllers/{id}
// answers without building or serialising anything.
// Thread-safe: the bridge writes from the controllers' strands, HTTP sessions read from theirs; the
// lock is held only to copy one shared_ptr.

#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace gw {

class controller_state_texts {
  public:
    void set(const std::string& id, std::shared_ptr<const std::string> text);
    // Null until the controller's first snapshot.
    std::shared_ptr<const std::string> get(const std::string& id) const;
    void forget(const std::string& id);

  private:
    mutable std::mutex mutex_;
    std::unordered_map<std::string, std::shared_ptr<const std::string>> texts_;
};

}  // namespace gw
