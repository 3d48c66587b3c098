#include "devices/share/telnet_codec.hpp"

namespace gw::devices::share {

namespace {

// Telnet commands (RFC 854).
constexpr std::uint8_t cmd_se = 240;  // the lowest command code
constexpr std::uint8_t cmd_sb = 250;
constexpr std::uint8_t cmd_will = 251;
constexpr std::uint8_t cmd_wont = 252;
constexpr std::uint8_t cmd_do = 253;
constexpr std::uint8_t cmd_dont = 254;
constexpr std::uint8_t iac = 255;

// Options the codec accepts; the index is their place in options_.
constexpr std::uint8_t opt_binary = 0;
constexpr std::uint8_t opt_sga = 3;
constexpr std::uint8_t opt_com_port = 44;
constexpr std::size_t binary_index = 0;
constexpr std::size_t sga_index = 1;
constexpr std::size_t com_port_index = 2;

// RFC 2217 commands from the client; the server answers with the same code + 100.
enum com_port_command : std::uint8_t {
    com_signature = 0,
    com_set_baudrate = 1,
    com_set_datasize = 2,
    com_set_parity = 3,
    com_set_stopsize = 4,
    com_set_control = 5,
    com_notify_linestate = 6,
    com_notify_modemstate = 7,
    com_set_linestate_mask = 10,
    com_set_modemstate_mask = 11,
    com_purge_data = 12,
};
constexpr std::uint8_t server_offset = 100;

// What the real link is, for queries.
constexpr std::uint8_t line_state_quiet = 0;

void send_option(std::string& reply, std::uint8_t verb, std::uint8_t option) {
    reply.push_back(static_cast<char>(iac));
    reply.push_back(static_cast<char>(verb));
    reply.push_back(static_cast<char>(option));
}

// IAC SB COM-PORT-OPTION <command> <value, IAC doubled> IAC SE.
void send_com_port(std::string& reply, std::uint8_t command, std::string_view value) {
    reply.push_back(static_cast<char>(iac));
    reply.push_back(static_cast<char>(cmd_sb));
    reply.push_back(static_cast<char>(opt_com_port));
    reply.push_back(static_cast<char>(command));
    for (const char c : value) {
        reply.push_back(c);
        if (static_cast<std::uint8_t>(c) == iac) reply.push_back(c);
    }
    reply.push_back(static_cast<char>(iac));
    reply.push_back(static_cast<char>(cmd_se));
}

void send_com_port(std::string& reply, std::uint8_t command, std::uint8_t value) {
    const char byte = static_cast<char>(value);
    send_com_port(reply, command, std::string_view(&byte, 1));
}

// SET-DATASIZE/PARITY/STOPSIZE: a value in the RFC's table is kept; the answer is what is kept (a query,
// 0, or a value outside the table gets the current one).
std::uint8_t take_setting(std::uint8_t value, std::uint8_t lowest, std::uint8_t highest, std::uint8_t& kept) {
    if (value >= lowest && value <= highest) kept = value;
    return kept;
}

}  // namespace

telnet_codec::telnet_codec(std::uint32_t line_baud) {
    port_.baud = line_baud;
}

bool telnet_codec::com_port_agreed() const {
    const option_state& com_port = options_[com_port_index];
    return com_port.us == side::yes || com_port.him == side::yes;
}

void telnet_codec::feed(std::string_view in, std::string& data, std::string& reply) {
    for (const char c : in) {
        const auto byte = static_cast<std::uint8_t>(c);
        switch (parse_) {
            case parse::data:
                if (byte == iac)
                    parse_ = parse::iac;
                else
                    take_data(byte, data);
                break;
            case parse::iac:
                parse_ = parse::data;
                take_command(byte, data, reply);
                break;
            case parse::option:
                parse_ = parse::data;
                negotiate(verb_, byte, reply);
                break;
            case parse::sub:
                if (byte == iac)
                    parse_ = parse::sub_iac;
                else
                    take_sub(c);
                break;
            case parse::sub_iac:
                if (byte == iac) {
                    parse_ = parse::sub;
                    take_sub(c);
                } else if (byte == cmd_se) {
                    parse_ = parse::data;
                    end_sub(reply);
                } else {
                    // Anything else ends the subnegotiation unfinished: it is dropped and the IAC read as
                    // outside one, so a client that lost an IAC SE gets back in step.
                    parse_ = parse::data;
                    take_command(byte, data, reply);
                }
                break;
        }
    }
}

void telnet_codec::take_data(std::uint8_t byte, std::string& data) {
    const bool client_binary = options_[binary_index].him == side::yes;
    const bool padding = byte == 0 && after_cr_ && telnet_seen_ && !client_binary;
    after_cr_ = byte == '\r';
    if (!padding) data.push_back(static_cast<char>(byte));
}

void telnet_codec::take_command(std::uint8_t byte, std::string& data, std::string& reply) {
    if (byte == iac) return take_data(iac, data);  // IAC IAC: a data byte 0xFF
    if (byte < cmd_se) {
        // No command: a raw client's 0xFF followed by an ordinary byte. Both are its data.
        take_data(iac, data);
        return take_data(byte, data);
    }
    if (!telnet_seen_) {
        telnet_seen_ = true;
        // Offer an 8-bit clean path both ways (pyserial and COM port drivers accept it).
        options_[binary_index] = {side::want_yes, side::want_yes};
        send_option(reply, cmd_will, opt_binary);
        send_option(reply, cmd_do, opt_binary);
    }
    switch (byte) {
        case cmd_will:
        case cmd_wont:
        case cmd_do:
        case cmd_dont:
            verb_ = byte;
            parse_ = parse::option;
            break;
        case cmd_sb:
            sub_size_ = 0;
            sub_too_long_ = false;
            parse_ = parse::sub;
            break;
        default:  // SE without SB, NOP, DM, BRK, IP, AO, AYT, EC, EL, GA: nothing a serial line could do
            break;
    }
}

telnet_codec::option_state* telnet_codec::state_of(std::uint8_t option) {
    switch (option) {
        case opt_binary:
            return &options_[binary_index];
        case opt_sga:
            return &options_[sga_index];
        case opt_com_port:
            return &options_[com_port_index];
        default:
            return nullptr;
    }
}

void telnet_codec::negotiate(std::uint8_t verb, std::uint8_t option, std::string& reply) {
    option_state* const state = state_of(option);
    const bool client_side = verb == cmd_will || verb == cmd_wont;  // about the client's own sending
    const bool enable = verb == cmd_will || verb == cmd_do;
    const std::uint8_t agree = client_side ? cmd_do : cmd_will;
    const std::uint8_t refuse = client_side ? cmd_dont : cmd_wont;
    if (state == nullptr) {
        // Refused options stay off: refuse each request, ignore their being turned off (already off).
        if (enable) send_option(reply, refuse, option);
        return;
    }
    side& current = client_side ? state->him : state->us;
    if (enable) {
        // NO: a request, agreed. WANTYES: the answer to our own offer. YES: nothing changes.
        if (current == side::no) send_option(reply, agree, option);
        current = side::yes;
    } else {
        // YES: turned off, which must be acknowledged. WANTYES: our offer refused. NO: nothing changes.
        if (current == side::yes) send_option(reply, refuse, option);
        current = side::no;
    }
    if (!modem_state_sent_ && com_port_agreed()) {
        // RFC 2217's initial MODEMSTATE-MASK is 255: tell the modem lines once, as a port would on change.
        modem_state_sent_ = true;
        send_com_port(reply, static_cast<std::uint8_t>(com_notify_modemstate + server_offset), modem_state);
    }
}

void telnet_codec::take_sub(char byte) {
    if (sub_size_ < sub_.size())
        sub_[sub_size_++] = byte;
    else
        sub_too_long_ = true;
}

void telnet_codec::end_sub(std::string& reply) {
    if (sub_too_long_ || sub_size_ < 2 || static_cast<std::uint8_t>(sub_[0]) != opt_com_port ||
        !com_port_agreed())
        return;
    const auto command = static_cast<std::uint8_t>(sub_[1]);
    const std::string_view value(sub_.data() + 2, sub_size_ - 2);
    const auto answer = static_cast<std::uint8_t>(command + server_offset);
    const std::optional<std::uint8_t> byte =
        value.size() == 1 ? std::optional(static_cast<std::uint8_t>(value[0])) : std::nullopt;

    switch (command) {
        case com_signature:
            if (value.empty()) send_com_port(reply, answer, signature);  // else the client's own, to read
            break;
        case com_set_baudrate: {
            if (value.size() != 4) break;
            std::uint32_t asked = 0;
            for (const char c : value)
                asked = (asked << 8) | static_cast<std::uint8_t>(c);
            if (asked != 0) {
                port_.baud = asked;
                send_com_port(reply, answer, value);
                break;
            }
            const std::array<char, 4> baud = {
                static_cast<char>(port_.baud >> 24), static_cast<char>(port_.baud >> 16),
                static_cast<char>(port_.baud >> 8), static_cast<char>(port_.baud)};
            send_com_port(reply, answer, std::string_view(baud.data(), baud.size()));
            break;
        }
        case com_set_datasize:
            if (byte) send_com_port(reply, answer, take_setting(*byte, 5, 8, port_.datasize));
            break;
        case com_set_parity:
            if (byte) send_com_port(reply, answer, take_setting(*byte, 1, 5, port_.parity));
            break;
        case com_set_stopsize:
            if (byte) send_com_port(reply, answer, take_setting(*byte, 1, 3, port_.stopsize));
            break;
        case com_set_control:
            if (byte) {
                if (const auto control = take_control(*byte)) send_com_port(reply, answer, *control);
            }
            break;
        case com_notify_linestate:
            if (value.empty()) send_com_port(reply, answer, line_state_quiet);  // a poll
            break;
        case com_notify_modemstate:
            if (value.empty()) send_com_port(reply, answer, modem_state);  // a poll
            break;
        case com_set_linestate_mask:
        case com_set_modemstate_mask:
            // Nothing changes on the line, so no notification ever depends on the masks.
            if (byte) send_com_port(reply, answer, *byte);
            break;
        case com_purge_data:
            if (byte && *byte >= 1 && *byte <= 3) send_com_port(reply, answer, *byte);
            break;
        default:  // FLOWCONTROL-SUSPEND/RESUME (no answer defined), unknown commands
            break;
    }
}

std::optional<std::uint8_t> telnet_codec::take_control(std::uint8_t value) {
    // RFC 2217 section 3, SET-CONTROL: each group has a query value and the values that set it.
    auto group = [&](std::uint8_t& kept, std::uint8_t query) {
        if (value != query) kept = value;
        return kept;
    };
    if (value <= 3 || value == 17 || value == 19) return group(port_.outbound_flow, 0);
    if (value <= 6) return group(port_.brk, 4);
    if (value <= 9) return group(port_.dtr, 7);
    if (value <= 12) return group(port_.rts, 10);
    if (value <= 16 || value == 18) return group(port_.inbound_flow, 13);
    return std::nullopt;  // 20..255: undefined
}

void telnet_codec::encode(std::string_view data, std::string& out) const {
    if (!telnet_seen_) {
        out.append(data);
        return;
    }
    for (const char c : data) {
        out.push_back(c);
        if (static_cast<std::uint8_t>(c) == iac) out.push_back(c);
    }
}

}  // namespace gw::devices::share
