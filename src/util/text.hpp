// A number as error messages show it: the stream's default format (six
// significant digits, so 0.005 stays 0.005 and 1e+06 stays short).
// Trade-off: not round-trippable; files that must read back exactly (XDMF,
// reports) print with full precision instead.
#pragma once
#include <sstream>
#include <string>

namespace parode {

inline std::string short_number(double x) {
    std::ostringstream os;
    os << x;
    return os.str();
}

}  // namespace parode
