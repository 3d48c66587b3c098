#pragma once
// Job and lease identifiers.
//
// A job id is "j-" + 26 Crockford base32 characters (0-9, A-Z without I L O U): a 48-bit millisecond
// time stamp (10 characters) then 80 random bits (16 characters), like a ULID. Ids made by one process
// are strictly increasing (within one millisecond the random part counts up), so string order is
// creation order: the job store lists newest first by id and pages with "before=<id>".
//
//   std::string id = make_job_id();       // "j-01JD4ZQ3M0Z8B1K2W6R9T5X7YA"
//   std::string lease = make_lease_id();  // "l-" + 32 lowercase hex characters

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace gw::jobs {

inline constexpr std::size_t job_id_length = 28;  // "j-" + 26

// A new id from the system clock and std::random_device; thread-safe, increasing within the process.
std::string make_job_id();
// The id of a given time stamp and random part (pure; ms uses its low 48 bits).
std::string format_job_id(std::uint64_t epoch_ms, const std::array<std::uint8_t, 10>& random);
// "j-" + 26 Crockford base32 characters (upper case) whose first character is 0..7 (48-bit time).
bool is_job_id(std::string_view s);
// The creation time (epoch ms) encoded in a job id; empty when `s` is not one.
std::optional<std::uint64_t> job_id_time_ms(std::string_view s);

// "l-" + 32 lowercase hex characters from std::random_device (128 bits): unguessable lease ids.
std::string make_lease_id();

}  // namespace gw::jobs
