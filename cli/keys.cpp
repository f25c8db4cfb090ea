// `parode keys`: the scene-file reference, every key the reader accepts with
// its table, type, unit, range, default and meaning (scene/scene_keys.hpp),
// printed as Markdown (the README's reference is this output), and with
// --json FILE written as JSON for tools.
// Trade-off: the text comes from the same table the reader checks keys
// against, so it cannot list a key the reader refuses or miss one it accepts;
// ranges and defaults are restated there and held equal by a test.
#include <iostream>

#include "cli_common.hpp"
#include "processes.hpp"
#include "scene/scene_keys.hpp"

namespace parode::cli {

void add_keys(CLI::App& app, KeysArgs& a, std::function<int()>& action) {
    CLI::App* k = app.add_subcommand("keys", "Print the scene-file reference (every TOML key) as Markdown");
    k->add_option("--json", a.json, "Also write the table as JSON");
    k->callback([&] {
        action = [&] {
            if (!Processes::current()->root()) return 0;
            if (!a.json.empty()) check_output_path("--json", a.json);
            std::cout << scene_keys_markdown();
            if (!a.json.empty()) write_json(a.json, scene_keys_json());
            return 0;
        };
    });
}

}  // namespace parode::cli
