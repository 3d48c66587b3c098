// Placeholder until the probe lands: the defaults, without asking the controller.
#include "gateway/jobs/motion_probe.hpp"

#include <boost/asio/post.hpp>

#include "gateway/controller_registry.hpp"

namespace gw::jobs {

void async_read_motion_model(controller_registry& registry, const std::string& controller_id,
                             const std::string& request_id, std::function<void(motion_model)> done) {
    (void)controller_id;
    (void)request_id;
    (void)registry;
    done(motion_model{});
}

}  // namespace gw::jobs
