// Joint parameter names used in scene files, mapped to ODE's dParam codes.
// A trailing "2" or "3" selects ODE's second or third axis group.
// Trade-off: a fixed table; a name outside it is a scene error, never ignored.
#include <ode/ode.h>

#include <string>

#include "scene/generators.hpp"

namespace parode {
namespace {

struct ParamName {
    const char* name;
    int code;
};

constexpr ParamName kParams[] = {
    {"lo_stop", dParamLoStop},         {"hi_stop", dParamHiStop},   {"vel", dParamVel},
    {"fmax", dParamFMax},              {"fudge_factor", dParamFudgeFactor},
    {"bounce", dParamBounce},          {"cfm", dParamCFM},          {"stop_erp", dParamStopERP},
    {"stop_cfm", dParamStopCFM},       {"suspension_erp", dParamSuspensionERP},
    {"suspension_cfm", dParamSuspensionCFM}, {"erp", dParamERP},
};

}  // namespace

int joint_param_code(const std::string& name) {
    int group = 0;
    std::string base = name;
    if (!base.empty() && (base.back() == '2' || base.back() == '3')) {
        group = base.back() - '1';
        base.pop_back();
    }
    for (const auto& p : kParams) {
        if (base == p.name) return p.code + group * dParamGroup;
    }
    return -1;
}

bool joint_param_known(const std::string& name) { return joint_param_code(name) >= 0; }

std::string joint_param_names() {
    std::string out;
    for (const auto& p : kParams) out += (out.empty() ? "" : ", ") + std::string(p.name);
    return out + " (add 2 or 3 for the second or third axis)";
}

}  // namespace parode
