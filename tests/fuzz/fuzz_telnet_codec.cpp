// telnet_codec on arbitrary client bytes cut at arbitrary points.
// Input: byte 0 = seed of the split points (and of a peer's choices), then the bytes. Checks: pieces give
// what one feed gives; the data is a subsequence of the input (all of it for a raw client); the replies
// are whole Telnet commands (negotiations, COM-PORT-OPTION answers), at most one per request; encode() is
// undone by a Telnet reader; the codec and a careless peer answering each other fall silent (no
// negotiation loop). The codec's own state has a fixed size (static_assert below).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <utility>

#include "devices/share/telnet_codec.hpp"

namespace share = gw::devices::share;

namespace {

constexpr std::uint8_t iac = 255;
constexpr std::uint8_t se = 240;
constexpr std::uint8_t sb = 250;
constexpr std::uint8_t will = 251;
constexpr std::uint8_t wont = 252;
constexpr std::uint8_t do_ = 253;
constexpr std::uint8_t dont = 254;

// Names the failed check's line (the target is built with optimisation, where traces lose lines).
void check(bool condition, int line = __builtin_LINE()) {
    if (condition) return;
    std::fprintf(stderr, "fuzz_telnet_codec.cpp:%d: check failed\n", line);
    std::abort();
}

bool is_subsequence(std::string_view part, std::string_view whole) {
    std::size_t at = 0;
    for (const char c : part) {
        at = whole.find(c, at);
        if (at == std::string_view::npos) return false;
        ++at;
    }
    return true;
}

// The reply is IAC WILL/WONT/DO/DONT <option> or IAC SB 44 <100..112> <value, IAC doubled> IAC SE, nothing
// else.
void check_reply(std::string_view reply) {
    std::size_t i = 0;
    const auto at = [&](std::size_t n) { return static_cast<std::uint8_t>(reply[n]); };
    while (i < reply.size()) {
        check(at(i) == iac && i + 1 < reply.size());
        const std::uint8_t verb = at(i + 1);
        if (verb >= will && verb <= dont) {
            check(i + 2 < reply.size());
            i += 3;
            continue;
        }
        check(verb == sb && i + 3 < reply.size());
        check(at(i + 2) == 44 && at(i + 3) >= 100 && at(i + 3) <= 112);
        i += 4;
        std::size_t value = 0;
        for (;;) {
            check(i + 1 < reply.size());
            if (at(i) == iac) {
                check(at(i + 1) == iac || at(i + 1) == se);
                i += 2;
                if (at(i - 1) == se) break;
            } else {
                ++i;
            }
            ++value;
        }
        check(value <= share::telnet_codec::signature.size() + 1);
    }
}

// The negotiations and subnegotiations in a well-formed reply.
std::pair<std::size_t, std::size_t> count_reply(std::string_view reply) {
    std::size_t negotiations = 0;
    std::size_t subnegotiations = 0;
    for (std::size_t i = 0; i + 1 < reply.size(); ++i) {
        if (static_cast<std::uint8_t>(reply[i]) != iac) continue;
        const auto next = static_cast<std::uint8_t>(reply[i + 1]);
        if (next >= will && next <= dont) {
            ++negotiations;
            i += 2;  // the option may be 255
        } else {
            subnegotiations += next == se ? 1 : 0;
            ++i;  // SB, SE, or the second IAC of a pair
        }
    }
    return {negotiations, subnegotiations};
}

// A peer's answers to the codec's reply: WILL x -> DO/DONT x, DO x -> WILL/WONT x, as bit x % 64 of
// `accepted` says; nothing for WONT, DONT and subnegotiations.
std::string careless_answers(std::string_view reply, std::uint64_t accepted) {
    std::string answers;
    for (std::size_t i = 0; i + 2 < reply.size(); ++i) {
        if (static_cast<std::uint8_t>(reply[i]) != iac) continue;
        const auto verb = static_cast<std::uint8_t>(reply[i + 1]);
        const auto option = static_cast<std::uint8_t>(reply[i + 2]);
        if (verb == sb) {
            // Skip to the IAC SE, stepping over the value's IAC IAC pairs.
            for (i += 2; i + 1 < reply.size(); ++i) {
                if (static_cast<std::uint8_t>(reply[i]) != iac) continue;
                if (static_cast<std::uint8_t>(reply[i + 1]) == se) break;
                ++i;
            }
            ++i;
            continue;
        }
        if (verb != will && verb != do_) {
            i += 2;
            continue;
        }
        const bool yes = ((accepted >> (option % 64)) & 1u) != 0;
        answers.push_back(static_cast<char>(iac));
        answers.push_back(static_cast<char>(verb == will ? (yes ? do_ : dont) : (yes ? will : wont)));
        answers.push_back(static_cast<char>(option));
        i += 2;
    }
    return answers;
}

// What a Telnet reader makes of encode()'s output: IAC IAC -> 0xFF.
std::string undouble(std::string_view encoded) {
    std::string out;
    for (std::size_t i = 0; i < encoded.size(); ++i) {
        out.push_back(encoded[i]);
        if (static_cast<std::uint8_t>(encoded[i]) == iac) {
            check(i + 1 < encoded.size() && static_cast<std::uint8_t>(encoded[i + 1]) == iac);
            ++i;
        }
    }
    return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    std::uint32_t seed = data[0] * 2654435761u + 7;
    const std::string_view input(reinterpret_cast<const char*>(data + 1), size - 1);
    static_assert(sizeof(share::telnet_codec) < 256, "the codec's state has a fixed, small size");

    share::telnet_codec whole(9600);
    std::string whole_data;
    std::string whole_reply;
    whole.feed(input, whole_data, whole_reply);

    share::telnet_codec pieces(9600);
    std::string piece_data;
    std::string piece_reply;
    std::size_t pos = 0;
    while (pos < input.size()) {
        seed = seed * 1103515245u + 12345u;
        const std::size_t n = std::min<std::size_t>(input.size() - pos, (seed >> 16) % 19);
        pieces.feed(input.substr(pos, n), piece_data, piece_reply);
        pos += n;
    }
    check(piece_data == whole_data);
    check(piece_reply == whole_reply);
    check(pieces.telnet_seen() == whole.telnet_seen());
    check(pieces.com_port_agreed() == whole.com_port_agreed());
    check(pieces.settings().baud == whole.settings().baud);
    check(pieces.settings().parity == whole.settings().parity);
    check(pieces.settings().dtr == whole.settings().dtr);

    // Every data byte came from the input, in order; a raw client's bytes pass unchanged.
    check(is_subsequence(whole_data, input));
    if (input.find(static_cast<char>(iac)) == std::string_view::npos) check(whole_data == input);
    if (!whole.telnet_seen()) check(whole_reply.empty());

    // Answers: whole commands only, each answering one request (Q method: never more than one), plus the
    // two offers and the one unasked NOTIFY-MODEMSTATE. Counted by IAC pairs, which over-counts requests.
    check_reply(whole_reply);
    std::size_t negotiations_in = 0;
    std::size_t subnegotiations_in = 0;
    for (std::size_t i = 0; i + 1 < input.size(); ++i) {
        if (static_cast<std::uint8_t>(input[i]) != iac) continue;
        const auto next = static_cast<std::uint8_t>(input[i + 1]);
        negotiations_in += next >= will && next <= dont ? 1 : 0;
        subnegotiations_in += next == se ? 1 : 0;
    }
    const auto [negotiations_out, subnegotiations_out] = count_reply(whole_reply);
    check(negotiations_out <= negotiations_in + 2);
    check(subnegotiations_out <= subnegotiations_in + 1);

    // encode(): a Telnet reader gets the data back; a raw client gets it as is.
    std::string encoded;
    whole.encode(input, encoded);
    if (whole.telnet_seen())
        check(undouble(encoded) == input);
    else
        check(encoded == input);

    // Negotiation must not loop, even with a careless peer that answers every WILL and DO it gets (with
    // an acceptance per option taken from the seed) and never keeps state. IAC SE IAC SE first ends
    // whatever command or subnegotiation the input left open.
    std::string resync_data;
    std::string to_peer = whole_reply;
    whole.feed("\xff\xf0\xff\xf0", resync_data, to_peer);
    check_reply(to_peer);
    const std::uint64_t accepted = (std::uint64_t{seed} << 32) | std::uint32_t{seed * 2654435761u};
    std::string exchanged_data;
    int rounds = 0;
    while (!to_peer.empty()) {
        check(++rounds <= 3);
        const std::string to_whole = careless_answers(to_peer, accepted);
        to_peer.clear();
        whole.feed(to_whole, exchanged_data, to_peer);
        check_reply(to_peer);
    }
    check(exchanged_data.empty());
    return 0;
}
