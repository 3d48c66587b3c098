#pragma once
// After a (re)connect the gateway reads its own retained birth back from the broker and publishes it
// again when the broker does not serve it. A clustered broker can acknowledge a retained publish and
// still lose it: on a NATS JetStream cluster electing the leader of its retained-message stream after
// a node's death, the surviving nodes went on serving the birth from before the failover. Fleet
// software reads the fleet from the retained births, so a stale one shows a gateway on a dead node.
//
// A while after the connect (check_delay) the status topic is subscribed (QoS 0, a subscription of
// its own) and the retained message the broker sends for it is compared with the newest birth
// published: the same, the check ends; another one, or none within answer_wait, and the birth and
// the states are published again (`republish`) and the check repeats, the delay doubling, at most
// max_rounds times. On the bridge's strand only.

#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

namespace spdlog {
class logger;
}

namespace gw::api {

struct mqtt_message_in;

// The check's waits (shorter in tests).
struct retained_birth_timing {
    std::chrono::milliseconds check_delay{2000};
    std::chrono::milliseconds answer_wait{3000};
    int max_rounds = 5;
};

class retained_birth_check {
  public:
    using strand = boost::asio::strand<boost::asio::any_io_executor>;
    struct hooks {
        std::function<void(const std::string& topic)> watch;    // subscribe, QoS 0, not kept
        std::function<void(const std::string& topic)> unwatch;  // unsubscribe
        std::function<void()> republish;                        // the birth and every state again
    };

    retained_birth_check(strand s, std::string status_topic, hooks h, std::shared_ptr<spdlog::logger> log,
                         retained_birth_timing t = {});

    void connected();                                  // a connect's birth is out: check it soon
    void disconnected();                               // nothing to check until the next connect
    void birth_published(const std::string& payload);  // what the broker should keep from now on
    // True when `in` is on the status topic (the check's, whatever it says).
    bool on_message(const mqtt_message_in& in);

  private:
    void schedule(std::chrono::milliseconds delay);
    void ask();  // subscribe, and wait for the retained birth
    void mismatch(const std::string& why);

    strand strand_;
    std::string topic_;
    hooks hooks_;
    std::shared_ptr<spdlog::logger> log_;
    retained_birth_timing timing_;
    boost::asio::steady_timer timer_;
    std::string expected_;          // the newest birth published
    int round_ = 0;                 // republishes since the connect
    bool asking_ = false;           // subscribed, waiting for the retained birth
    std::uint64_t generation_ = 0;  // a connect or disconnect ends the checks of the one before
};

}  // namespace gw::api
