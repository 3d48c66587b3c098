#include "gateway/jobs/plan_worker.hpp"

namespace gw::jobs {

plan_worker::~plan_worker() {
    pool_.stop();
    pool_.join();
}

}  // namespace gw::jobs
