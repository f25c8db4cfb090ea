// Scene files: TOML -> Scene, with overrides and full validation.
// Trade-off: one schema function per table keeps each error next to the key it
// checks; generators (the catom prism) expand compact tables into bodies here.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "scene/generators.hpp"  // CatomPlan
#include "scene/scene.hpp"
#include "scene/toml_reader.hpp"

namespace parode {

// Called once the scene is validated up to the catom prism, before the prism's
// bodies are generated (a count of 1e8 is 20 GB of bodies): it may throw to
// refuse a scene too large for the machine before memory is spent on it.
using BeforeCatoms = std::function<void(const Scene& so_far, const CatomPlan& catoms)>;

// Load, apply `--set` overrides in order, validate and expand. Throws SceneError
// (and whatever `before_catoms` throws).
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {},
                 const BeforeCatoms& before_catoms = {});

// Same, from TOML text (for tests and embedded scenes); `name` is used in errors.
Scene load_scene_text(const std::string& text, const std::string& name,
                      const std::vector<std::string>& overrides = {});

}  // namespace parode
