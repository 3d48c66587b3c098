#pragma once
// Not compiled: the fixture of the layering_check test. A gateway/ header that includes up into api/
// and into a folder its library may not use, and one allowed include.

#include "api/common/problem.hpp"
#include "gateway/common/timestamp.hpp"
#include "gateway/jobs/job.hpp"
