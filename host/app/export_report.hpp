// What a take left out or held, one line each on stderr (voxcap export, fit and demo share it).
#pragma once

#include "voxcap/export/take.hpp"

namespace vc::cli {

// `what` names the command in the lines ("export", "demo").
void report_take(const take::Take& take, const char* what);

}  // namespace vc::cli
