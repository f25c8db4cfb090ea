// Scene files: TOML -> Scene, with overrides and full validation.
// Trade-off: one schema function per table keeps each error next to the key it
// checks; generators (the catom prism) expand compact tables into bodies here.
#pragma once
#include <string>
#include <vector>

#include "scene/scene.hpp"
#include "scene/toml_reader.hpp"

namespace parode {

// Load, apply `--set` overrides in order, validate and expand. Throws SceneError.
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});

// Same, from TOML text (for tests and embedded scenes); `name` is used in errors.
Scene load_scene_text(const std::string& text, const std::string& name,
                      const std::vector<std::string>& overrides = {});

}  // namespace parode
