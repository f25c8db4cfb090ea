// The "magnets/omp" force pass: MagnetPass (src/forces/magnets) whose
// per-body gather runs on the execution's threads with dynamic scheduling.
// Each body's wrench is computed by one thread in the serial order of its
// neighbours, so the result is bit for bit the serial one for any thread
// count; applying the wrenches stays serial, in id order (dBodyAddForce is
// safe only on distinct bodies, and order fixes the sums).
// Pole positions and cell keys are computed on the execution's loops; the
// cell list is sorted serially (mostly a pass: it starts from last step's
// order). Trade-off: applying the wrenches stays on one thread.
#pragma once
#include <vector>

#include "exec/execution.hpp"
#include "forces/magnets.hpp"

namespace parode::omp {

class MagnetPassOmp final : public MagnetPass {
public:
    MagnetPassOmp(const Scene& scene, const Execution& exec) : MagnetPass(scene), exec_(exec) {}
    std::string name() const override { return "magnets/omp"; }

protected:
    void gather_all(const MagnetField& field, std::vector<BodyWrench>& out) const override;
    const LoopRunner& loops() const override { return exec_.loops(); }

private:
    const Execution& exec_;
};

// Magnetised bodies below which the gather runs on one thread.
constexpr std::size_t kMagnetCrossover = 1024;

}  // namespace parode::omp
