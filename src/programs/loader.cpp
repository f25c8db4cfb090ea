// Programs by name: a built-in one, or a shared library (a path ending in
// .so) loaded with dlopen that exports `parode_program`, returning its
// ProgramSpec. Libraries stay loaded until the process ends (their code runs
// in every catom's handlers until then).
// Trade-off: the library must be built against the same parode headers and
// compiler as the program (a C++ interface, not a C one): the CMake helper
// parode_add_program() of the installed package does that.
#include <dlfcn.h>

#include <map>
#include <mutex>

#include "programs/program.hpp"
#include "util/errors.hpp"

namespace parode {
namespace {

bool is_library(const std::string& s) { return s.size() > 3 && s.compare(s.size() - 3, 3, ".so") == 0; }

std::string known() {
    std::string out;
    for (const std::string& n : builtin_program_names()) out += (out.empty() ? "" : ", ") + n;
    return out;
}

const ProgramSpec& open_library(const std::string& path) {
    static std::mutex lock;
    static std::map<std::string, const ProgramSpec*> open;
    std::lock_guard<std::mutex> guard(lock);
    if (auto it = open.find(path); it != open.end()) return *it->second;
    void* h = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!h) throw ProgramError("cannot load the program library " + path + ": " + dlerror());
    void* entry = dlsym(h, "parode_program");
    if (!entry) {
        throw ProgramError("the program library " + path +
                           " has no entry point parode_program (declare it extern \"C\" const "
                           "parode::ProgramSpec* parode_program())");
    }
    const ProgramSpec* spec = reinterpret_cast<ProgramEntry>(entry)();
    if (!spec || !spec->make) throw ProgramError("the program library " + path + " gave no program (null, or no factory)");
    if (spec->values.size() > static_cast<std::size_t>(kProgramValues)) {
        throw ProgramError("the program library " + path + " names " + std::to_string(spec->values.size()) +
                           " values; at most " + std::to_string(kProgramValues));
    }
    open[path] = spec;
    return *spec;
}

}  // namespace

const ProgramSpec& load_program(const std::string& name) {
    if (is_library(name)) return open_library(name);
    if (const ProgramSpec* s = builtin_program(name)) return *s;
    throw ProgramError("unknown program '" + name + "': expected a built-in program (" + known() +
                       ") or a program library's path ending in .so");
}

}  // namespace parode
