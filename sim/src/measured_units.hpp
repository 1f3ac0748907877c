#pragma once
// The units a measurement description names (sim/src/measured.cpp's reader and writer), private to it.
#include <vector>

#include "orbcal/sim/se3.hpp"

namespace orbcal::sim::measured_units {

// ---------------------------------------------------------------------------------------------
// Units: value_SI = value * multiply / divide + offset (divide keeps mm -> m exact as v / 1000).

struct Unit {
  const char* name = "";
  double multiply = 1.0;
  double divide = 1.0;
  double offset = 0.0;
  double toSi(double v) const {
    const double scaled = v * multiply / divide;
    return offset == 0.0 ? scaled : scaled + offset;  // keeps -0.0 as written
  }
  double fromSi(double si) const { return (si - offset) * divide / multiply; }
};

const std::vector<Unit> kAngleUnits = {{"rad"}, {"deg", kDegToRad}};
const std::vector<Unit> kLengthUnits = {{"m"}, {"mm", 1.0, 1000.0}};
const std::vector<Unit> kTorqueUnits = {{"N*m"}, {"Nm"}};
const std::vector<Unit> kTemperatureUnits = {{"degC"}, {"K", 1.0, 1.0, -273.15}};
const std::vector<Unit> kTimeUnits = {{"s"}, {"ms", 1.0, 1000.0}, {"min", 60.0}, {"h", 3600.0}};

}  // namespace orbcal::sim::measured_units
