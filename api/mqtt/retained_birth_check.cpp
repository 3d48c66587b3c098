#include "api/mqtt/retained_birth_check.hpp"

#include <utility>

#include <spdlog/logger.h>

#include "api/mqtt/mqtt_client.hpp"

namespace gw::api {

retained_birth_check::retained_birth_check(strand s, std::string status_topic, hooks h,
                                           std::shared_ptr<spdlog::logger> log, retained_birth_timing t)
    : strand_(std::move(s)),
      topic_(std::move(status_topic)),
      hooks_(std::move(h)),
      log_(std::move(log)),
      timing_(t),
      timer_(strand_) {}

void retained_birth_check::connected() {
    ++generation_;
    round_ = 0;
    asking_ = false;
    schedule(timing_.check_delay);
}

void retained_birth_check::disconnected() {
    ++generation_;
    asking_ = false;
    timer_.cancel();
}

void retained_birth_check::birth_published(const std::string& payload) {
    expected_ = payload;
}

void retained_birth_check::schedule(std::chrono::milliseconds delay) {
    timer_.expires_after(delay);
    timer_.async_wait([this, generation = generation_](boost::system::error_code ec) {
        if (!ec && generation == generation_) ask();
    });
}

void retained_birth_check::ask() {
    asking_ = true;
    hooks_.watch(topic_);
    timer_.expires_after(timing_.answer_wait);
    timer_.async_wait([this, generation = generation_](boost::system::error_code ec) {
        if (!ec && generation == generation_ && asking_) mismatch("no retained birth");
    });
}

bool retained_birth_check::on_message(const mqtt_message_in& in) {
    if (in.topic != topic_) return false;
    // Only the broker's stored copy counts (a live birth of ours comes without the retain flag).
    if (!asking_ || !in.retained) return true;
    if (in.payload != expected_) {
        mismatch("an older retained birth");
        return true;
    }
    asking_ = false;
    timer_.cancel();
    hooks_.unwatch(topic_);
    if (round_ > 0 && log_)
        log_->info("mqtt: the broker serves the retained birth after {} republish(es)", round_);
    return true;
}

void retained_birth_check::mismatch(const std::string& why) {
    asking_ = false;
    hooks_.unwatch(topic_);
    if (round_ >= timing_.max_rounds) {
        if (log_)
            log_->warn(
                "mqtt: the broker still serves {} after {} republishes; giving up until the next "
                "connect (the broker's ACL must let the gateway read its own status topic)",
                why, round_);
        return;
    }
    ++round_;
    if (log_)
        log_->log(round_ == 1 ? spdlog::level::warn : spdlog::level::info,
                  "mqtt: the broker serves {}; publishing the birth and states again", why);
    hooks_.republish();
    schedule(timing_.check_delay * (1 << (round_ - 1)));
}

}  // namespace gw::api
