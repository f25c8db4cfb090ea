// Command-line helpers (see cli_common.hpp).
#include "cli_common.hpp"

#include <cstdlib>
#include <iostream>

#include "collide.hpp"
#include "pipeline.hpp"
#include "scene_file.hpp"

namespace parode::cli {

int resolve_threads(int requested) {
    if (requested > 0) return requested;
    if (const char* env = std::getenv("OMP_NUM_THREADS")) {
        const int n = std::atoi(env);
        if (n > 0) return n;
    }
    return 1;
}

std::string backend_list() {
    std::string out;
    for (const auto& n : BackendRegistry::instance().names()) out += (out.empty() ? "" : ", ") + n;
    return out;
}

int guarded(const std::function<int()>& action) {
    try {
        return action ? action() : 0;
    } catch (const SceneError& e) {
        std::cerr << "parode: scene error: " << e.what() << "\n";
        return kExitScene;
    } catch (const SimulationError& e) {
        std::cerr << "parode: simulation failed: " << e.what() << "\n";
        return kExitSimulation;
    } catch (const std::invalid_argument& e) {
        std::cerr << "parode: " << e.what() << "\n";
        return kExitUsage;
    } catch (const std::exception& e) {
        std::cerr << "parode: " << e.what() << "\n";
        return kExitOutput;
    }
}

}  // namespace parode::cli
