#pragma once
// A job run that records (spec.record): the positions the controller reports at each trigger while the
// run lasts, in a recording of its own (gateway/recordings) that names the job. It starts before the
// run moves anything and stops once the run ends, however it ends; "recording" events in the job's
// history name it and tell how it ended.
//
// The run owns the trigger input, as it owns every setting it changes: when the input is off it sets
// TTL X=1 (on a build with the TTL_REPORT module any non-zero mode sends a frame per edge) and
// registers TTL X=<before> as a restore command, so that a stopped or crashed run gets it back through
// the job's recovery, after the job type's own restore commands (newest first). A run that ends by
// itself puts it back as its last command. The recording touches no setting.

#include <memory>

#include <boost/asio/awaitable.hpp>

namespace gw::recordings {
class recorder;
}

namespace gw::jobs {

class job_execution;

// run_job(exec) inside a recording. job_failure before anything moves when the recording cannot start
// (no recorder, the controller records already, the store is full, it is away) or the input cannot be
// set; otherwise what the run throws, after the recording has stopped.
boost::asio::awaitable<void> run_recorded(std::shared_ptr<recordings::recorder> recorder,
                                          job_execution& exec);

}  // namespace gw::jobs
