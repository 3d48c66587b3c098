#include "gateway/jobs/manager/worker_thread.hpp"

namespace gw::jobs {

worker_thread::~worker_thread() {
    pool_.stop();
    pool_.join();
}

}  // namespace gw::jobs
