#pragma once
// The controllers whose report frames a running job counts as TTL edges. The registry's observer asks
// for every frame, on the controller's strand: a frame no job counts stays there, instead of crossing
// to the job manager's thread (a post and a thread wake per frame, 500 frames/s per controller).
// Thread-safe; counted, so that two runs overlapping on one controller cannot unregister each other.
//
//   listeners.add("sim1");                // a run starts on sim1
//   if (listeners.listening("sim1")) ...  // a frame of sim1
//   listeners.remove("sim1");             // the run has ended

#include <atomic>
#include <cstddef>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace gw::jobs {

class ttl_edge_listeners {
  public:
    void add(const std::string& controller);
    void remove(const std::string& controller);
    bool listening(std::string_view controller) const;

  private:
    std::atomic<std::size_t> total_{0};  // without any run, a frame costs one atomic load
    mutable std::mutex mutex_;
    std::map<std::string, std::size_t, std::less<>> runs_;  // controller -> runs registered
};

}  // namespace gw::jobs
