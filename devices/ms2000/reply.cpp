#include "devices/ms2000/reply.hpp"
