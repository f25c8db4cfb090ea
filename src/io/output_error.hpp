// OutputError: a file the user asked parode to write (report, trajectory,
// snapshot, CSV) cannot be opened or written.
// Trade-off: a type of its own rather than a message convention, so the command
// line maps it to its exit code by type; it derives from std::runtime_error so
// code that only wants a message still catches it.
#pragma once
#include <stdexcept>

namespace parode {

class OutputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace parode
