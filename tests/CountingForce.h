#ifndef OPENMM_FLAVORS_TESTS_COUNTING_FORCE_H_
#define OPENMM_FLAVORS_TESTS_COUNTING_FORCE_H_

#include "openmm/Force.h"
#include "openmm/internal/ForceImpl.h"
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace FlavorTests {

/**
 * A force that adds nothing but counts how often its force group is evaluated: an independent witness of the
 * number of force evaluations an integrator makes.
 */
class CountingForce : public OpenMM::Force {
public:
    CountingForce() : count(std::make_shared<int>(0)) {}
    int getCount() const { return *count; }

protected:
    OpenMM::ForceImpl* createImpl() const override;

private:
    std::shared_ptr<int> count;
    friend class CountingForceImpl;
};

class CountingForceImpl : public OpenMM::ForceImpl {
public:
    explicit CountingForceImpl(const CountingForce& owner) : owner(owner) {}
    void initialize(OpenMM::ContextImpl& /*context*/) override {}
    const OpenMM::Force& getOwner() const override { return owner; }
    void updateContextState(OpenMM::ContextImpl& /*context*/, bool& /*forcesInvalid*/) override {}
    double calcForcesAndEnergy(OpenMM::ContextImpl& /*context*/, bool includeForces, bool /*includeEnergy*/,
                               int groups) override {
        if (includeForces && (groups & (1 << owner.getForceGroup())) != 0)
            ++*owner.count;
        return 0.0;
    }
    std::map<std::string, double> getDefaultParameters() override { return {}; }
    std::vector<std::string> getKernelNames() override { return {}; }

private:
    const CountingForce& owner;
};

inline OpenMM::ForceImpl* CountingForce::createImpl() const {
    return new CountingForceImpl(*this);
}

} // namespace FlavorTests

#endif
