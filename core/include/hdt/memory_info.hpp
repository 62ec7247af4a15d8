// The declarations moved to the public hdt/host_memory.hpp (the VTK layer uses them too).
#pragma once

#include "hdt/host_memory.hpp"
