#pragma once
// Not compiled: the fixture of the layering_check test. A gateway/ header that includes up into api/
// and into the composition root, and one allowed include.

#include "api/problem.hpp"
#include "gateway/app/application.hpp"
#include "gateway/common/timestamp.hpp"
