#include "gateway/common/worker_thread.hpp"

namespace gw {

worker_thread::~worker_thread() {
    pool_.stop();
    pool_.join();
}

}  // namespace gw
