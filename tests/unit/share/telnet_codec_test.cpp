#include "devices/share/telnet_codec.hpp"

#include <string>
#include <string_view>

#include <gtest/gtest.h>

namespace gw::devices::share {
namespace {

using namespace std::string_literals;

constexpr std::uint32_t line_baud = 9600;  // 0x00002580

// What the codec says on the client's first Telnet command: WILL BINARY, DO BINARY.
const std::string offers = "\xff\xfb\x00\xff\xfd\x00"s;
// The client's WILL COM-PORT-OPTION, and what it gets back: the offers (it is the first command),
// DO COM-PORT-OPTION and the one unasked NOTIFY-MODEMSTATE (CD, DSR, CTS).
const std::string will_com_port = "\xff\xfb\x2c"s;
const std::string notify_modem = "\xff\xfa\x2c\x6b\xb0\xff\xf0"s;
const std::string com_port_agreed = offers + "\xff\xfd\x2c"s + notify_modem;

// IAC SB COM-PORT-OPTION <command> <value as written: IAC already doubled> IAC SE.
std::string com_port(unsigned char command, const std::string& value) {
    return "\xff\xfa\x2c"s + static_cast<char>(command) + value + "\xff\xf0"s;
}
// A request after the option was agreed, and the answer that follows the agreement.
std::string agreed_then(const std::string& request) {
    return will_com_port + request;
}
std::string agreed_reply(const std::string& answer) {
    return com_port_agreed + answer;
}

struct codec_case {
    std::string name;
    std::string input;
    std::string data;
    std::string reply;
};

class telnet_test : public ::testing::TestWithParam<codec_case> {};

TEST_P(telnet_test, in_one_feed) {
    const codec_case& c = GetParam();
    telnet_codec codec(line_baud);
    std::string data;
    std::string reply;
    codec.feed(c.input, data, reply);
    EXPECT_EQ(data, c.data);
    EXPECT_EQ(reply, c.reply);
}

TEST_P(telnet_test, byte_by_byte) {
    const codec_case& c = GetParam();
    telnet_codec codec(line_baud);
    std::string data;
    std::string reply;
    for (const char byte : c.input)
        codec.feed(std::string_view(&byte, 1), data, reply);
    EXPECT_EQ(data, c.data);
    EXPECT_EQ(reply, c.reply);
}

TEST_P(telnet_test, at_every_split_point) {
    const codec_case& c = GetParam();
    const std::string_view input = c.input;
    for (std::size_t cut = 0; cut <= input.size(); ++cut) {
        telnet_codec codec(line_baud);
        std::string data;
        std::string reply;
        codec.feed(input.substr(0, cut), data, reply);
        codec.feed(input.substr(cut), data, reply);
        EXPECT_EQ(data, c.data) << "cut at " << cut;
        EXPECT_EQ(reply, c.reply) << "cut at " << cut;
    }
}

// pyserial 3.5 (Debian's python3-serial) opening rfc2217://: DO ECHO, WILL SGA, DO SGA, DO COM-PORT,
// WILL COM-PORT, then its answers to our offers (WILL BINARY, DO BINARY), the port settings (115200 8N1),
// no flow control, DTR on, RTS on, purge receive and transmit buffers; then a line with a 0xFF.
const std::string pyserial_open = "\xff\xfd\x01\xff\xfb\x03\xff\xfd\x03\xff\xfd\x2c\xff\xfb\x2c"s;
const std::string pyserial_open_reply = offers + "\xff\xfc\x01"s + "\xff\xfd\x03"s + "\xff\xfb\x03"s +
                                        "\xff\xfb\x2c"s + notify_modem + "\xff\xfd\x2c"s;
const std::string pyserial_settings = com_port(1, "\x00\x01\xc2\x00"s) + com_port(2, "\x08") +
                                      com_port(3, "\x01") + com_port(4, "\x01") + com_port(5, "\x01") +
                                      com_port(5, "\x08") + com_port(5, "\x0b") + com_port(12, "\x01") +
                                      com_port(12, "\x02");
const std::string pyserial_settings_reply =
    com_port(101, "\x00\x01\xc2\x00"s) + com_port(102, "\x08") + com_port(103, "\x01") +
    com_port(104, "\x01") + com_port(105, "\x01") + com_port(105, "\x08") + com_port(105, "\x0b") +
    com_port(112, "\x01") + com_port(112, "\x02");

INSTANTIATE_TEST_SUITE_P(raw, telnet_test,
                         ::testing::Values(codec_case{"text", "2H X=100 Y=-20\r", "2H X=100 Y=-20\r", ""},
                                           codec_case{"cr_nul_kept", "A\r\0B"s, "A\r\0B"s, ""},
                                           codec_case{"ff_then_letter",
                                                      "\xff"
                                                      "A",
                                                      "\xff"
                                                      "A",
                                                      ""},
                                           codec_case{"ff_ff", "\xff\xff", "\xff", ""},
                                           codec_case{"nothing", "", "", ""}),
                         [](const auto& info) { return info.param.name; });

INSTANTIATE_TEST_SUITE_P(
    telnet, telnet_test,
    ::testing::Values(
        codec_case{"nop_offers_binary",
                   "A\xff\xf1"
                   "B",
                   "AB", offers},
        codec_case{"other_commands_consumed",
                   "X\xff\xf2\xff\xf3\xff\xf4\xff\xf5\xff\xf6\xff\xf7\xff\xf8\xff\xf9\xff\xf0"
                   "Y",
                   "XY", offers},
        codec_case{"iac_iac_is_data",
                   "\xff\xf1"
                   "A\xff\xff"
                   "B",
                   "A\xff"
                   "B",
                   offers},
        codec_case{"nvt_cr_nul_is_cr",
                   "\xff\xf1"
                   "A\r\0B\r\nC\r"s,
                   "A\rB\r\nC\r", offers},
        codec_case{"nul_without_cr_kept",
                   "\xff\xf1"
                   "A\0B"s,
                   "A\0B"s, offers},
        codec_case{"cr_nul_kept_in_binary",
                   "\xff\xfb\x00"
                   "A\r\0B"s,
                   "A\r\0B"s, offers},
        codec_case{"cr_nul_stripped_after_binary_refused",
                   "\xff\xfc\x00"
                   "A\r\0B"s,
                   "A\rB", offers},
        codec_case{"data_around_commands", "AB" + will_com_port + "CD", "ABCD", com_port_agreed},
        codec_case{"pyserial_open", pyserial_open + "\xff\xfb\x00\xff\xfd\x00"s, "", pyserial_open_reply},
        codec_case{"pyserial_session",
                   pyserial_open + "\xff\xfb\x00\xff\xfd\x00"s + pyserial_settings + "V\xff\xff\r", "V\xff\r",
                   pyserial_open_reply + pyserial_settings_reply},
        codec_case{"refused_options",
                   "\xff\xfb\x01\xff\xfd\x01\xff\xfb\x18\xff\xfd\x1f\xff\xfc\x01\xff\xfe\x01", "",
                   offers + "\xff\xfe\x01\xff\xfc\x01\xff\xfe\x18\xff\xfc\x1f"},
        codec_case{"option_255_refused", "\xff\xfb\xff", "", offers + "\xff\xfe\xff"},
        codec_case{"client_side_answered_once",
                   "\xff\xfb\x03\xff\xfb\x03\xff\xfc\x03\xff\xfc\x03\xff\xfb\x03", "",
                   offers + "\xff\xfd\x03\xff\xfe\x03\xff\xfd\x03"},
        codec_case{"server_side_answered_once", "\xff\xfd\x03\xff\xfd\x03\xff\xfe\x03\xff\xfe\x03", "",
                   offers + "\xff\xfb\x03\xff\xfc\x03"},
        codec_case{"offers_accepted_silently", "\xff\xfd\x00\xff\xfb\x00\xff\xfd\x00\xff\xfb\x00"s, "",
                   offers},
        codec_case{"offers_refused_silently_then_asked", "\xff\xfe\x00\xff\xfc\x00\xff\xfd\x00"s, "",
                   offers + "\xff\xfb\x00"s},
        codec_case{"binary_turned_off", "\xff\xfb\x00\xff\xfc\x00"s, "", offers + "\xff\xfe\x00"s},
        codec_case{"com_port_by_do", "\xff\xfd\x2c", "", offers + "\xff\xfb\x2c" + notify_modem},
        codec_case{"modem_state_told_once", will_com_port + "\xff\xfc\x2c" + will_com_port, "",
                   com_port_agreed + "\xff\xfe\x2c\xff\xfd\x2c"}),
    [](const auto& info) { return info.param.name; });

INSTANTIATE_TEST_SUITE_P(
    rfc2217, telnet_test,
    ::testing::Values(
        codec_case{"before_agreement_ignored", com_port(1, "\x00\x00\x25\x80"s), "", offers},
        codec_case{"baud_set", agreed_then(com_port(1, "\x00\x01\xc2\x00"s)), "",
                   agreed_reply(com_port(101, "\x00\x01\xc2\x00"s))},
        codec_case{"baud_query", agreed_then(com_port(1, "\x00\x00\x00\x00"s)), "",
                   agreed_reply(com_port(101, "\x00\x00\x25\x80"s))},
        codec_case{"baud_with_iac", agreed_then(com_port(1, "\x00\x00\x00\xff\xff"s)), "",
                   agreed_reply(com_port(101, "\x00\x00\x00\xff\xff"s))},
        codec_case{"baud_wrong_size", agreed_then(com_port(1, "\x00\x25\x80"s) + com_port(1, "")), "",
                   com_port_agreed},
        codec_case{"datasize", agreed_then(com_port(2, "\x00"s) + com_port(2, "\x07") + com_port(2, "\x09")),
                   "", agreed_reply(com_port(102, "\x08") + com_port(102, "\x07") + com_port(102, "\x07"))},
        codec_case{"parity", agreed_then(com_port(3, "\x00"s) + com_port(3, "\x03") + com_port(3, "\x06")),
                   "", agreed_reply(com_port(103, "\x01") + com_port(103, "\x03") + com_port(103, "\x03"))},
        codec_case{"stopsize", agreed_then(com_port(4, "\x00"s) + com_port(4, "\x02") + com_port(4, "\x04")),
                   "", agreed_reply(com_port(104, "\x01") + com_port(104, "\x02") + com_port(104, "\x02"))},
        codec_case{"one_byte_setting_wrong_size", agreed_then(com_port(2, "") + com_port(3, "\x01\x01")), "",
                   com_port_agreed},
        codec_case{"control_queries",
                   agreed_then(com_port(5, "\x00"s) + com_port(5, "\x04") + com_port(5, "\x07") +
                               com_port(5, "\x0a") + com_port(5, "\x0d")),
                   "",
                   agreed_reply(com_port(105, "\x01") + com_port(105, "\x06") + com_port(105, "\x08") +
                                com_port(105, "\x0b") + com_port(105, "\x0e"))},
        codec_case{"control_settings_echoed",
                   agreed_then(com_port(5, "\x03") + com_port(5, "\x05") + com_port(5, "\x09") +
                               com_port(5, "\x0c") + com_port(5, "\x10") + com_port(5, "\x13")),
                   "",
                   agreed_reply(com_port(105, "\x03") + com_port(105, "\x05") + com_port(105, "\x09") +
                                com_port(105, "\x0c") + com_port(105, "\x10") + com_port(105, "\x13"))},
        // What a virtual COM driver set is what it reads back (the real link is not touched).
        codec_case{"queries_tell_what_was_set",
                   agreed_then(com_port(1, "\x00\x00\x4b\x00"s) + com_port(1, "\x00\x00\x00\x00"s) +
                               com_port(5, "\x03") + com_port(5, "\x00"s) + com_port(5, "\x05") +
                               com_port(5, "\x04") + com_port(5, "\x09") + com_port(5, "\x07") +
                               com_port(5, "\x0c") + com_port(5, "\x0a") + com_port(5, "\x12") +
                               com_port(5, "\x0d") + com_port(5, "\x13") + com_port(5, "\x00"s)),
                   "",
                   agreed_reply(com_port(101, "\x00\x00\x4b\x00"s) + com_port(101, "\x00\x00\x4b\x00"s) +
                                com_port(105, "\x03") + com_port(105, "\x03") + com_port(105, "\x05") +
                                com_port(105, "\x05") + com_port(105, "\x09") + com_port(105, "\x09") +
                                com_port(105, "\x0c") + com_port(105, "\x0c") + com_port(105, "\x12") +
                                com_port(105, "\x12") + com_port(105, "\x13") + com_port(105, "\x13"))},
        codec_case{"control_undefined_ignored", agreed_then(com_port(5, "\x14") + com_port(5, "\x08\x08")),
                   "", com_port_agreed},
        codec_case{"signature_asked", agreed_then(com_port(0, "")), "",
                   agreed_reply(com_port(100, "asi-gateway"))},
        codec_case{"signature_told", agreed_then(com_port(0, "pyserial")), "", com_port_agreed},
        codec_case{"polls", agreed_then(com_port(6, "") + com_port(7, "")), "",
                   agreed_reply(com_port(106, "\x00"s) + com_port(107, "\xb0"))},
        codec_case{"client_notifications_ignored", agreed_then(com_port(6, "\x01") + com_port(7, "\x10")), "",
                   com_port_agreed},
        codec_case{"flow_control_suspend_resume_ignored", agreed_then(com_port(8, "") + com_port(9, "")), "",
                   com_port_agreed},
        codec_case{"masks_echoed", agreed_then(com_port(10, "\xff\xff") + com_port(11, "\x00"s)), "",
                   agreed_reply(com_port(110, "\xff\xff") + com_port(111, "\x00"s))},
        codec_case{"purge",
                   agreed_then(com_port(12, "\x01") + com_port(12, "\x03") + com_port(12, "\x00"s) +
                               com_port(12, "\x04")),
                   "", agreed_reply(com_port(112, "\x01") + com_port(112, "\x03"))},
        codec_case{"unknown_commands_ignored", agreed_then(com_port(13, "\x01") + com_port(101, "\x00"s)), "",
                   com_port_agreed},
        codec_case{"other_option_ignored", agreed_then("\xff\xfa\x18\x01\xff\xf0"s), "", com_port_agreed},
        codec_case{"empty_subnegotiations_ignored", agreed_then("\xff\xfa\xff\xf0\xff\xfa\x2c\xff\xf0"s), "",
                   com_port_agreed},
        codec_case{
            "too_long_dropped",
            agreed_then("\xff\xfa\x2c\x00"s + std::string(70, 'a') + "\xff\xf0" + com_port(0, "") + "Z"), "Z",
            agreed_reply(com_port(100, "asi-gateway"))},
        codec_case{"truncated_then_command",
                   agreed_then("\xff\xfa\x2c\x01\x00\x00"s + "\xff\xfb\x01"
                                                             "A"),
                   "A", agreed_reply("\xff\xfe\x01")},
        codec_case{"truncated_then_subnegotiation", agreed_then("\xff\xfa\x18\x01"s + com_port(5, "\x07")),
                   "", agreed_reply(com_port(105, "\x08"))},
        codec_case{"truncated_then_no_command",
                   agreed_then("\xff\xfa\x2c\x01\xff"
                               "A"),
                   "\xff"
                   "A",
                   com_port_agreed},
        codec_case{"unfinished_swallows_data",
                   agreed_then("\xff\xfa\x2c\x01"
                               "2H X?\r"),
                   "", com_port_agreed}),
    [](const auto& info) { return info.param.name; });

TEST(telnet_codec, raw_client_is_never_told_telnet) {
    telnet_codec codec(line_baud);
    std::string data;
    std::string reply;
    codec.feed("2H W X\r", data, reply);
    EXPECT_FALSE(codec.telnet_seen());
    EXPECT_FALSE(codec.com_port_agreed());
    std::string out;
    codec.encode(":A 1 \xff\r\n", out);
    EXPECT_EQ(out, ":A 1 \xff\r\n");
}

TEST(telnet_codec, telnet_client_gets_iac_doubled) {
    telnet_codec codec(line_baud);
    std::string data;
    std::string reply;
    codec.feed("\xff\xf1", data, reply);
    EXPECT_TRUE(codec.telnet_seen());
    std::string out = "kept";
    codec.encode(
        "\xff"
        "A\xff\xff\r\n",
        out);
    EXPECT_EQ(out,
              "kept\xff\xff"
              "A\xff\xff\xff\xff\r\n");
    out.clear();
    codec.encode("", out);
    EXPECT_EQ(out, "");
}

TEST(telnet_codec, flags_follow_the_negotiation) {
    telnet_codec codec(line_baud);
    std::string data;
    std::string reply;
    EXPECT_EQ(codec.settings().baud, line_baud);
    codec.feed(will_com_port, data, reply);
    EXPECT_TRUE(codec.telnet_seen());
    EXPECT_TRUE(codec.com_port_agreed());
    codec.feed(com_port(1, "\x00\x01\xc2\x00"s), data, reply);
    EXPECT_EQ(codec.settings().baud, 115200u);
    codec.feed(com_port(1, "\x00\x00\x00\x00"s), data, reply);  // a query asks nothing
    EXPECT_EQ(codec.settings().baud, 115200u);
    codec.feed("\xff\xfc\x2c", data, reply);
    EXPECT_FALSE(codec.com_port_agreed());
    reply.clear();
    codec.feed(com_port(1, "\x00\x00\x25\x80"s), data, reply);  // no longer agreed: ignored
    EXPECT_EQ(reply, "");
    EXPECT_EQ(codec.settings().baud, 115200u);
}

TEST(telnet_codec, line_baud_is_told_to_a_query) {
    telnet_codec codec(0x01ff0203);
    std::string data;
    std::string reply;
    codec.feed(will_com_port, data, reply);
    reply.clear();
    codec.feed(com_port(1, "\x00\x00\x00\x00"s), data, reply);
    EXPECT_EQ(reply, com_port(101, "\x01\xff\xff\x02\x03"));
}

TEST(telnet_codec, endless_subnegotiation_keeps_memory_bounded) {
    telnet_codec codec(line_baud);
    std::string data;
    std::string reply;
    codec.feed(will_com_port + "\xff\xfa\x2c\x00"s, data, reply);
    const std::string chunk(4096, 'x');
    for (int i = 0; i < 1024; ++i)
        codec.feed(chunk, data, reply);  // 4 MiB of one subnegotiation
    codec.feed(
        "\xff\xf0"
        "ok",
        data, reply);
    EXPECT_EQ(data, "ok");
    EXPECT_EQ(reply, com_port_agreed);
    static_assert(sizeof(telnet_codec) < 256, "the codec's state has a fixed, small size");
}

// Another codec reads a's answers to pyserial's open (and to a few refused requests) and the two answer
// each other: with the Q method every answer reads as an acknowledgment, so the exchange dies out.
TEST(telnet_codec, two_codecs_fall_silent) {
    telnet_codec a(line_baud);
    telnet_codec b(line_baud);
    std::string data;
    std::string to_b;
    a.feed(pyserial_open + "\xff\xfb\x18\xff\xfd\x01\xff\xfe\x00"s, data, to_b);
    int rounds = 0;
    while (!to_b.empty() && rounds < 10) {
        std::string to_a;
        b.feed(to_b, data, to_a);
        to_b.clear();
        a.feed(to_a, data, to_b);
        ++rounds;
    }
    EXPECT_TRUE(to_b.empty());
    EXPECT_LE(rounds, 2);
    EXPECT_EQ(data, "");  // answers carry no data
}

}  // namespace
}  // namespace gw::devices::share
