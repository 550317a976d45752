// The one gate for integers mpmrom reads as numbers (scene fields, --set values, parameters, datasets of its files):
// converting a double outside an integer type's range is undefined behaviour, and truncating 2.5 to 2 would
// silently run something other than what was asked for.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace mpmrom::impl {

// `value` as an Integer when it is a whole number in [lo, hi], narrowed to Integer's range and to 2^53 (below which
// doubles hold every integer); otherwise throws std::runtime_error("<name> must be a whole number in [lo, hi], not
// <value>"), where name() (called only then, so that checking large arrays builds no strings) names what was read.
template <class Integer, class Name>
Integer checked_integer(double value, const Name& name, double lo = -INFINITY, double hi = INFINITY) {
  constexpr double exact = 9007199254740992.0;  // 2^53
  lo = std::max({lo, double(std::numeric_limits<Integer>::lowest()), -exact});
  hi = std::min({hi, double(std::numeric_limits<Integer>::max()), exact});
  if (!(value >= lo && value <= hi && value == std::floor(value))) {
    const auto text = [](double v, int digits) {
      char buffer[32];
      std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
      return std::string(buffer);
    };
    // The bounds are whole numbers below 2^53: 17 digits print them exactly; 15 print the value as it was written.
    throw std::runtime_error(std::string(name()) + " must be a whole number in [" + text(lo, 17) + ", " + text(hi, 17) +
                             "], not " + text(value, 15));
  }
  return static_cast<Integer>(value);
}

}  // namespace mpmrom::impl
