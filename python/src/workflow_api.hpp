#pragma once
// The workflow functions the module calls (the parameter rows of a fit, diagnosis.json). They live in the
// workflow library (orbcal_workflow); a tree from before it has them in tools/ (orbcal_tools) under the same
// names, which python/CMakeLists.txt links instead.
#if __has_include("orbcal/workflow/diagnose.hpp")
#include "orbcal/workflow/diagnose.hpp"
#include "orbcal/workflow/measured.hpp"
#else
#include "diagnose.hpp"
#include "measured.hpp"
namespace orbcal {
namespace workflow = tools;
}
#endif
