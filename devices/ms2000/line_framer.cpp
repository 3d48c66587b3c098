#include "devices/ms2000/line_framer.hpp"
