#include "devices/ms2000/build_info.hpp"
