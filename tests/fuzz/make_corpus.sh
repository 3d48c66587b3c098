#!/usr/bin/env bash
# Writes the seed corpus (tests/fuzz/corpus/<name>/) from the wire examples of the protocol doc.
# printf keeps binary frames exact. Re-run after editing; the files are committed.
set -euo pipefail
cd "$(dirname "$0")/corpus"
mkdir -p reply build_info report_decoder line_framer command

# fuzz_reply: one framed reply line (no CR LF).
printf ':A' > reply/ack
printf ':A ' > reply/ack_space
printf ':A 1234.5 432.1 0 ' > reply/where
printf ':A X=7.500000 Y=7.5' > reply/speed
printf ':X=50 Y=50 Z=50 A' > reply/accel
printf 'X=10 Y=50 Z=50 F=0 :A' > reply/tgled
printf ':N-21' > reply/halted
printf 'B' > reply/busy
printf ':A Version: USB-9.2p ' > reply/version
printf 'STD_XYZ\rMotor Axes: X Y Z\rRING BUFFER 50' > reply/build
printf 'T:   400    0.0    0.1' > reply/position_report
printf ':A F' > reply/lock_state

# fuzz_build_info: the BUILD X text without its final CR LF.
printf 'STD_XYZ_SEQ\rMotor Axes: X Y Z\rCMDs: XYZFTR\rBootLdr V:1\rHdwr REV.E\rLL COMMANDS\rRING BUFFER\rSEARCH INDEX\rARRAY MODULE\rINO_INT\rDAC OUT\rSEQUENCER\rPLANAR CORRECTION' > build_info/manual
printf 'STD_XYZ\rMotor Axes: X Y Z\rAxis Types: x x z\rRING BUFFER 50\rARRAY MODULE\rSCAN MODULE' > build_info/doc_example
printf 'WK_XYZ_TRACER\rMotor Axes: X Y Z\rTTL_REPORT_INT\rSERIAL OUT\rBINARY_OUTPUT\rLED DIMMER\rCRISP' > build_info/tracer
printf ':A STD_XY\r\nRING BUFFER 250\rDLED' > build_info/ack_prefix

# fuzz_report_decoder: byte 0 = format bit | expected axes << 1, byte 1 = split seed, then the stream.
printf '\x00\x07\x18\xd2\x04\x00\x00\x19\xfb\xff\xff\xff\x1a\x00\x00\x00\x00\x0d' > report_decoder/binary_xyz
printf '\x06\x03\x18\x0d\x0d\x0d\x0d\x19\x18\x0d\x1a\x1a\x1a\x00\x00\x00\x80\x0d\x18\x01\x00\x00\x00\x19\x02\x00\x00\x00\x1a\x03\x00\x00\x00\x0d' > report_decoder/binary_cr_counts
printf '\x00\x11\xff\x00\x18\x01\x02\x18\x05\x00\x00\x00\x0d\x1b\xff\xff\xff\x7f\x0d' > report_decoder/binary_garbage
printf '\x00\x21\x18\x00\x00\x00\x00\x19\x00\x00\x00\x00\x1a\x00\x00\x00\x00\x1b\x00\x00\x00\x00\x1c\x00\x00\x00\x00\x1d\x00\x00\x00\x00\x1e\x00\x00\x00\x00\x1f\x01\x00\x00\x00\x0d' > report_decoder/binary_8_axes
printf '\x01\x05X=1234 Y=-5 Z=0\r\nX=1 Y=2\rgarbage\r\nZ=-2147483648\n' > report_decoder/ascii
printf '\x07\x09X=1 Y=2 Z=3\r\nX=1 Y=2\r\n' > report_decoder/ascii_expected_3

# fuzz_line_framer: byte 0 = line bound (0 = default), byte 1 = split seed, then the bytes.
printf '\x00\x01:A\r\n:A 1234.5 0 \r\nN\r\n' > line_framer/replies
printf '\x00\x02STD_XYZ\rMotor Axes: X Y Z\rCRISP\r\n' > line_framer/multiline
printf '\x08\x03\n:\rA\r\n0123456789abcdef\r\nB\r\n' > line_framer/overflow
printf '\x00\x04:A\r\r\n\r\nX=1\n' > line_framer/odd_ends

# fuzz_command: a raw command line (also read as a make_command program, see fuzz_command.cpp).
printf 'W X Y Z' > command/where
printf 'M X=1234.5 Y=-10' > command/move
printf 'SS Z' > command/saveset
printf 'BU X' > command/build
printf '/' > command/status
printf '\\' > command/halt
printf 'X=1\rM Y=2' > command/injection
printf 'INFO X' > command/info
printf '\x03TTLX\x00\x04\x00\x00\x00\x00\x00\x00\xf8\x3fY\x01\x02\x00\x00\x00\x00\x00\x00\x00\x00' > command/make_command

# fuzz_gcode: byte 0 = option flags (1 least-increment, 2 analog Z, 4 scale 0.01, 8 coarse arcs,
# 16 custom analog limits, 32 analog range error), then the program.
mkdir -p gcode
printf '\x00%%\nO0001 (SAMPLE)\nG90 G21 G17\nG00 X1. Y2.\nG01 Z- .1 F300\nM03\nG02 X3. Y2. I1.\nG03 X1. Y2. R-1.\nM05\nG04 P250\nM30\n%%\n' > gcode/basic
printf '\x02G20 G0 X1 Y.5\nG01 F10. Z-.001\nG18 G02 X2. Z0 I.5 K0\nG19 G03 Y1. Z0 J.5\n' > gcode/analog_inch
printf '\x01G91 G16 G01 X20. Y20. F60\nX20 Y20\nG15 G90 G02 Z5. I5.\n/N0 G0 X1000 ; G1 Y2\n' > gcode/polar_incremental
printf '\x08G0 X1. X2.\nG28\n(a (b))\nG1 X F1\nG04 P1.5\n' > gcode/errors

# fuzz_controller_data: byte 0 = chunk size seed, then what a controller might send on its main port.
mkdir -p controller_data
printf '\x05:A Version: USB-9.52 \r\nSTD_XYZ\rMotor Axes: X Y Z\rRING BUFFER 50\r\n:A X=10000 Y=10000 Z=10000\r\n:A X=-110 Y=-110 Z=-110\r\n:A X=0 Y=0\r\n:A 1234.5 -555.1 77.7 \r\nB\r\n:A B\r\n' > controller_data/identify_and_poll
printf '\x03:A 12\xc3(\xff 3\r\nT:   400    0.0    0.1\r\n\x80\x81:N-21\r\n:A ASI-MS2000 STD_XYZ\r\n' > controller_data/noise

# fuzz_token_config: byte 0 = reader (0 digest, 1 token strength, 2 tokens file), then the text.
mkdir -p token_config
printf '\x009f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08' > token_config/digest
printf '\x00ABCDEF0123456789abcdef0123456789abcdef0123456789abcdef012345678' > token_config/digest_short
printf '\x01kQ2v9TzX4mB7wR1yH8nL3pD6sF0gJ5cA' > token_config/strong
printf '\x01change-me-operator-token' > token_config/placeholder
printf '\x02[{"name": "s", "role": "operator", "token": "kQ2v9TzX4mB7wR1yH8nL3pD6sF0gJ5cA"}]' > token_config/plain_file
printf '\x02[{"name": "s", "token_sha256": "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08"}]' > token_config/hashed_file

# fuzz_mqtt_signed_command: byte 0 even = an envelope follows, odd = replay-guard steps (nonce, ts step).
mkdir -p mqtt_signed_command
printf '\x00{"key": "scheduler", "ts": 1764921600123, "nonce": "6f1c2a9b0e4d7c35", "sig": "%s", "body": "{\\"operation\\":\\"halt\\"}"}' "$(printf 'a%.0s' $(seq 64))" > mqtt_signed_command/signed
printf '\x00{"key": "k", "ts": 1, "nonce": "x", "sig": "%s", "body": "{}"}' "$(printf '0%.0s' $(seq 64))" > mqtt_signed_command/bad_nonce
printf '\x00{"operation": "halt", "token": "t"}' > mqtt_signed_command/bearer
printf '\x01\x01\x05\x01\x05\x02\xc8\x01\x0a\x03\x46\x01\x3f' > mqtt_signed_command/replays
