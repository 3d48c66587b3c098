#pragma once
// The Telnet layer of a shared port's TCP connection (RFC 854/855) with the Com Port Control option of
// RFC 2217, so that pyserial's rfc2217:// URLs and virtual COM port drivers can open the port as well as
// programs that send raw bytes. Pure: no I/O, no clock; its state has a fixed size (a subnegotiation is
// kept up to max_subnegotiation_bytes, a longer one is dropped). Throws nothing of its own. One codec per
// connection, used on its session's strand only.
//
// A raw client (one that never sent a Telnet command) gets its bytes through unchanged both ways, as on a
// serial line; a 0xFF byte from it is still read as IAC (a shared port cannot tell the two apart, and the
// controller's commands are ASCII), though IAC followed by a byte below 240 is no command and both bytes
// pass as data. On the client's first command (IAC followed by 240..254) the codec
// offers WILL BINARY and DO BINARY, so the data path is 8-bit clean both ways, and from then on doubles
// IAC in what it sends. Without BINARY from the client, NVT's CR NUL is read as CR (RFC 854). Output gets
// no CR NUL: the controller's replies go out as the controller sent them.
//
// Negotiation is the Q method of RFC 1143, so no negotiation loops: BINARY (0), SUPPRESS-GO-AHEAD (3) and
// COM-PORT-OPTION (44) are accepted both ways, every other option refused (ECHO too: pyserial asks DO ECHO
// at open but takes WONT). A request that does not change an option's state gets no answer, nor does the
// client's answer to our own offer. Other Telnet commands (NOP, DM, BRK, IP, AO, AYT, EC, EL, GA) are
// consumed without an answer: a serial line has no way to give one (the controller's replies show it is
// there).
//
// RFC 2217 requests (IAC SB 44 <command> <value> IAC SE, accepted once option 44 is agreed either way) are
// answered with command + 100 and never change the real serial link, which the gateway owns. The client
// sees a port of its own (port_settings) that keeps what it set, as a serial port would: a virtual COM
// driver that sets 9600 7E1 and reads the settings back finds them, while the controller's link stays as
// it is:
// - a setting with a value is kept and acknowledged by echoing it (SET-BAUDRATE, any value;
//   SET-DATASIZE 5..8, SET-PARITY 1..5, SET-STOPSIZE 1..3; SET-CONTROL 1..3, 5, 6, 8, 9, 11, 12, 14..19);
//   a value outside the RFC's table is answered with the current one, i.e. refused;
//   SET-LINESTATE-MASK, SET-MODEMSTATE-MASK and PURGE-DATA 1..3 are echoed;
// - a query tells the current setting: SET-BAUDRATE 0, SET-DATASIZE/PARITY/STOPSIZE 0, SET-CONTROL 0
//   (outbound flow control), 4 (BREAK), 7 (DTR), 10 (RTS), 13 (inbound flow control); before any setting
//   that is the real link (line_baud, 8, NONE, 1) with no flow control, BREAK off, DTR and RTS on;
//   SIGNATURE with no text -> `signature`; NOTIFY-MODEMSTATE / NOTIFY-LINESTATE with no value
//   (pyserial's poll_modem) -> modem_state / 0;
// - once option 44 is first agreed, one NOTIFY-MODEMSTATE (modem_state) is sent unasked, so that
//   pyserial's cts/dsr/cd have a value (the state never changes afterwards, so none follows);
// - ignored: a client's own SIGNATURE text or NOTIFY value, FLOWCONTROL-SUSPEND/RESUME (RFC 2217 §5
//   defines no answer; TCP already paces what the gateway sends), malformed values, unknown commands and
//   options, and every subnegotiation before option 44 is agreed.
// Inside a subnegotiation IAC IAC is a 0xFF of its value; it ends at IAC SE, and any other IAC byte pair
// drops it unfinished and is read as outside one (a client whose IAC SE got lost is back in step at its
// next command; until then its bytes belong to the subnegotiation).
// Each request is answered once, in arrival order; a command split across feed() calls at any byte is
// read exactly as if it came in one.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace gw::devices::share {

class telnet_codec {
  public:
    // Option, command and value of one subnegotiation (IAC IAC counted once); a longer one is dropped.
    static constexpr std::size_t max_subnegotiation_bytes = 64;
    // Answered to SIGNATURE with no text.
    static constexpr std::string_view signature = "asi-gateway";
    // The modem lines reported by NOTIFY-MODEMSTATE: carrier detect, DSR and CTS on, no deltas.
    static constexpr std::uint8_t modem_state = 0xB0;

    // `line_baud`: the real link's rate, answered to a baud query (SET-BAUDRATE 0).
    explicit telnet_codec(std::uint32_t line_baud);

    // Bytes from the client: data bytes are appended to `data`, answers to `reply` (to send back to the
    // client as they are, before anything encode() produces later).
    void feed(std::string_view in, std::string& data, std::string& reply);

    // Data for the client, appended to `out`: IAC doubled once the client has spoken Telnet, else as is.
    void encode(std::string_view data, std::string& out) const;

    // The client sent at least one Telnet command.
    bool telnet_seen() const { return telnet_seen_; }
    // RFC 2217's option 44 is agreed in at least one direction.
    bool com_port_agreed() const;
    // The port as the client set it (RFC 2217 values); the real link keeps its own.
    struct port_settings {
        std::uint32_t baud = 0;
        std::uint8_t datasize = 8;
        std::uint8_t parity = 1;         // NONE
        std::uint8_t stopsize = 1;       // 1
        std::uint8_t outbound_flow = 1;  // none
        std::uint8_t brk = 6;            // BREAK off
        std::uint8_t dtr = 8;            // on
        std::uint8_t rts = 11;           // on
        std::uint8_t inbound_flow = 14;  // none
    };
    const port_settings& settings() const { return port_; }

  private:
    // Where the byte stream stands between feed() calls.
    enum class parse : std::uint8_t { data, iac, option, sub, sub_iac };
    // One side of an option (RFC 1143). No WANTNO: the codec never asks to turn an option off.
    enum class side : std::uint8_t { no, want_yes, yes };
    struct option_state {
        side us = side::no;   // we WILL (the client's DO/DONT)
        side him = side::no;  // the client WILL (its WILL/WONT)
    };

    void take_data(std::uint8_t byte, std::string& data);
    void take_command(std::uint8_t byte, std::string& data, std::string& reply);
    void negotiate(std::uint8_t verb, std::uint8_t option, std::string& reply);
    void take_sub(char byte);
    void end_sub(std::string& reply);
    option_state* state_of(std::uint8_t option);
    // A SET-CONTROL value: kept in its group unless it is the group's query; the answer is the group's
    // setting. None for a value the RFC leaves undefined (20..255).
    std::optional<std::uint8_t> take_control(std::uint8_t value);

    port_settings port_;
    parse parse_ = parse::data;
    std::uint8_t verb_ = 0;                             // WILL/WONT/DO/DONT waiting for its option byte
    std::array<char, max_subnegotiation_bytes> sub_{};  // option, command, value (IAC IAC as one 0xFF)
    std::size_t sub_size_ = 0;
    bool sub_too_long_ = false;
    std::array<option_state, 3> options_{};  // BINARY, SUPPRESS-GO-AHEAD, COM-PORT-OPTION
    bool telnet_seen_ = false;
    bool after_cr_ = false;  // the last data byte was CR: a NUL now is NVT padding
    bool modem_state_sent_ = false;
};

}  // namespace gw::devices::share
