// Scene tables that judge a run rather than describe it: [guard] (the bounds
// that stop a runaway run) and [checks] (the pass criteria of a hard case).
// Trade-off: criteria live in the scene file next to the scene they judge, so
// the CLI, the stability tests and the stability map apply the same ones.
#pragma once
#include "scene/scene.hpp"
#include "scene/toml_reader.hpp"

namespace parode {

void read_guard(const Node& root, GuardSpec& g);
// Needs the bodies (position checks name them), so it runs after [catoms].
void read_checks(const Node& root, Scene& sc);

}  // namespace parode
