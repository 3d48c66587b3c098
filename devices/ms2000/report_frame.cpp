#include "devices/ms2000/report_frame.hpp"
