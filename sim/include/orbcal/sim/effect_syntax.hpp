#pragma once
// The effect catalog's spec syntax, for --help: generated from the catalog (sim/effect.hpp), so that a
// kind added to it is in every list of the command line.
#include <string>

#include "orbcal/sim/effect.hpp"

namespace orbcal::sim {

/// A kind's spec syntax for --effects and --inject: "compliance:J,...[/K]" (J a joint from 1, K the
/// order), "thermal"; from its name, takesJoints and maxOrder.
std::string effectSyntax(const EffectKind& k);

/// Every kind's syntax, in the catalog's order, separated by spaces.
std::string effectSyntaxList();

}  // namespace orbcal::sim
