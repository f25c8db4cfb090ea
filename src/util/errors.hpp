// The errors a run can end with, one type each, so that the command line maps
// them to exit codes by type (cli/cli_common.cpp; README "Exit codes") and no
// stage prints its own failures or picks its own code. Each derives from
// std::runtime_error, so code that wants only a message catches them all.
// A bad option or value given by the caller is std::invalid_argument (exit 2).
// Trade-off: one header at the bottom of the layers, so that a stage of any
// layer can throw any of them without including the layer that defined it.
#pragma once
#include <stdexcept>

namespace parode {

// A scene file (or a --set override) that cannot be run: names the file, the
// line, the dotted key and what was expected. Exit code 3.
struct SceneError : std::runtime_error { using std::runtime_error::runtime_error; };

// A run that cannot go on (NaN, runaway energy or speed, a broken invariant):
// names the step and the bodies. Exit code 1.
struct SimulationError : std::runtime_error { using std::runtime_error::runtime_error; };

// A file the user asked parode to write (report, trajectory, snapshot,
// checkpoint) cannot be opened or written. Exit code 4.
struct OutputError : std::runtime_error { using std::runtime_error::runtime_error; };

// A --restart checkpoint that cannot be used: a checksum differs, it is
// truncated, or it is no checkpoint at all: names the file, the section and
// both values. Exit code 8.
struct CheckpointError : std::runtime_error { using std::runtime_error::runtime_error; };

// A catom program that fails: its library does not load or lacks the entry
// point, a handler throws, it messages a catom that is not a neighbour or
// sends past its budget; names the catom, the event and the message. Exit code 9.
struct ProgramError : std::runtime_error { using std::runtime_error::runtime_error; };

// A run refused because its memory estimate exceeds what the machine gives.
// Exit code 6 (as std::bad_alloc).
struct MemoryError : std::runtime_error { using std::runtime_error::runtime_error; };

}  // namespace parode
