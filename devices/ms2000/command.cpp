#include "devices/ms2000/command.hpp"
